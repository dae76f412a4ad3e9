"""The `discern` console script: the CLI, relaunched on jemalloc where the machine has it (allocator.py)."""

from __future__ import annotations

import signal
import sys

from .allocator import AllocatorError, relaunch

# Ctrl-C, a service manager's stop, and the hangup of a closed terminal (sent to the whole job) stop a monitor, which
# then lets its decision workers finish what they were sent (those ignore the three). By default SIGHUP killed it as
# kill -9 would (exit 129, no summary line, a log file without its footer).
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


def discern_command() -> int:
    if sys.argv[1:2] in (["serve"], ["router"]):
        # A stop asked for while the monitor starts is held, not lost, until serve's own handlers take it (the
        # mask survives the relaunch's exec; a blocked signal stays pending even where a shell ignores it)
        signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        relaunch()
    except AllocatorError as exc:
        print(f"discern: error: {exc}", file=sys.stderr)
        return 2
    from discern.monitor.cli import main

    return main()
