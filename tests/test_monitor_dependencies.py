"""The monitor's own dependencies: torch and the simulator are the planner side's, not the sidecar's."""

import subprocess
import sys

IMPORT_EVERY_MODULE = """
import importlib, pkgutil, sys
import discern.adapters, discern.monitor, discern.rules, discern.sanity, discern.scenarios
imported = ["discern.adapters.avcsr"]
for package in (discern.monitor, discern.rules, discern.sanity, discern.scenarios):
    imported += [module.name for module in pkgutil.walk_packages(package.__path__, package.__name__ + ".")]
for name in imported:
    importlib.import_module(name)
print(len(imported), sorted(name for name in ("torch", "highway_env", "gymnasium", "matplotlib") if name in sys.modules))
"""


def test_every_module_of_the_monitor_rules_sanity_layer_and_scenarios_imports_without_the_planner_side():
    done = subprocess.run([sys.executable, "-c", IMPORT_EVERY_MODULE], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    count, planner_side = done.stdout.strip().split(" ", 1)
    assert int(count) > 40 and planner_side == "[]"
