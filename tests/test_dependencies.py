"""The monitor's own dependencies, and which way the parts import each other."""

import subprocess
import sys

IMPORT_EVERY_MODULE = """
import importlib, pkgutil, sys
import discern.adapters, discern.monitor, discern.rules, discern.sanity, discern.scenarios
imported = ["discern.adapters.avcsr"]
for package in (discern.monitor, discern.rules, discern.sanity, discern.scenarios):
    imported += [module.name for module in pkgutil.walk_packages(package.__path__, package.__name__ + ".")
                 if not module.name.startswith("discern.scenarios.highway")]  # the closed loop: the planner side
for name in imported:
    importlib.import_module(name)
print(len(imported), sorted(name for name in ("torch", "highway_env", "gymnasium", "matplotlib") if name in sys.modules))
"""


def test_every_module_of_the_monitor_rules_sanity_layer_and_scenario_runner_imports_without_the_planner_side():
    done = subprocess.run([sys.executable, "-c", IMPORT_EVERY_MODULE], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    count, planner_side = done.stdout.strip().split(" ", 1)
    assert int(count) > 40 and planner_side == "[]"

UPSTREAM_ONLY = """
import importlib, pkgutil, sys
import discern.adapters, discern.rules, discern.sanity
imported = []
for package in (discern.adapters, discern.rules, discern.sanity):
    imported += [module.name for module in pkgutil.walk_packages(package.__path__, package.__name__ + ".")]
for name in imported:
    importlib.import_module(name)
print(len(imported), sorted({m.split(".")[1] for m in sys.modules if m.startswith("discern.")}))
"""


def test_adapters_rules_and_the_sanity_layer_import_nothing_downstream_of_them():
    """Data flows one way: adapters -> scene -> rules and sanity -> verdict -> monitor, and the closed loop on top."""
    done = subprocess.run([sys.executable, "-c", UPSTREAM_ONLY], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    count, parts = done.stdout.strip().split(" ", 1)
    assert int(count) > 25 and parts == "['adapters', 'rules', 'sanity']"
