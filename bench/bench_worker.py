"""The sidecar's decision workers under load, without zenoh: how many proposals the rules decide in time.

Run: python bench/bench_worker.py [--seconds 8]   (writes the "Decision workers under load" section of docs/benchmarks.md)

The round-trip benchmark (bench_zenoh.py) shares two cores among the load generator, zenoh, the
monitor process and its workers, so its figures move with all of them. This one feeds a real
DecisionPool (worker processes, pipes, batching, shedding) straight from a timer, as the monitor's
zenoh callbacks would, and counts what comes back.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.bench_zenoh import payloads  # noqa: E402
from bench.report import machine, pct, write_section  # noqa: E402
from discern.monitor.allocator import relaunch  # noqa: E402
from discern.monitor.decision_pool import DecisionPool  # noqa: E402
from discern.monitor.decision_worker import Job, Outcome, WorkerSettings  # noqa: E402

BUDGET_S = 0.05  # the monitor's default decision budget
VEHICLES = 10
RATES = (50, 100, 150, 200, 300, 500)  # proposals per second, all vehicles together: from below one worker's capacity to past two's
WARM_UP_S = 2.0  # at a light load first, so that each worker has timed its batches, as a running monitor has


class Collector:
    def __init__(self) -> None:
        self.outcomes: dict[int, Outcome] = {}
        self._all_in = threading.Condition()

    def __call__(self, outcome: Outcome) -> None:
        with self._all_in:
            self.outcomes[outcome.rid] = outcome
            self._all_in.notify_all()

    def wait_for(self, count: int, timeout_s: float) -> None:
        with self._all_in:
            self._all_in.wait_for(lambda: len(self.outcomes) >= count, timeout_s)


def feed(pool: DecisionPool, loads: dict[str, list[bytes]], rate: float, first_rid: int) -> int:
    """Submit every vehicle's frames in turn at `rate` proposals a second, each with the default budget."""
    jobs = [(vehicle, frames[f]) for f in range(len(next(iter(loads.values())))) for vehicle, frames in loads.items()]
    start = time.monotonic()
    for k, (vehicle, data) in enumerate(jobs):
        due = start + k / rate
        time.sleep(max(0.0, due - time.monotonic()))
        now = time.monotonic()
        pool.submit(Job(first_rid + k, vehicle, data, now, now + BUDGET_S), lambda: True)
    return len(jobs)


def run_case(workers: int, rate: float, seconds: float, objects: int) -> dict:
    collector = Collector()
    pool = DecisionPool(workers, WorkerSettings(window_s=2.0, shadow=False), collector, lambda *_: None)
    pool.start()
    try:
        warm = feed(pool, payloads("w", VEHICLES, int(WARM_UP_S * 5), objects), VEHICLES * 5.0, 0)
        collector.wait_for(warm, 30)
        sent = feed(pool, payloads("v", VEHICLES, int(seconds * rate / VEHICLES), objects), rate, warm)
        collector.wait_for(warm + sent, 60)
    finally:
        pool.stop()
    timed = [o for rid, o in collector.outcomes.items() if rid >= warm]
    decided = [o for o in timed if o.verdict is not None and not o.failsafe]
    in_time = [o for o in decided if o.latency_ms <= BUDGET_S * 1000]
    return {
        "sent": sent, "answered": len(timed), "decided": len(decided), "in_time": len(in_time),
        "shed": sum(o.verdict is None and o.no_verdict is not None and not o.internal for o in timed),
        "latencies": [o.latency_ms for o in decided],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="seconds of load per case")
    parser.add_argument("--objects", type=int, default=50, help="objects per scene")
    parser.add_argument("--no-docs", action="store_true", help="print only, leave docs/benchmarks.md alone")
    args = parser.parse_args()
    rows = []
    for workers in (1, 2):
        for rate in RATES:
            r = run_case(workers, rate, args.seconds, args.objects)
            lat = r["latencies"]
            rows.append(
                f"| {workers} | {rate} | {r['sent']} | {r['answered']} | {r['decided']} ({r['decided'] / r['sent']:.0%}) "
                f"| {r['in_time']} | {r['shed']} | {pct(lat, 50):.1f} | {pct(lat, 99):.1f} | {max(lat, default=float('nan')):.1f} |"
            )
            print(rows[-1], flush=True)
    body = "\n".join([
        "## Decision workers under load",
        "",
        f"Command: `python bench/bench_worker.py --seconds {args.seconds:g} --objects {args.objects}`  ",
        f"Machine: {machine()}; a DecisionPool of 1 or 2 worker processes (as `discern serve --workers`), fed "
        f"from a timer in this process, no zenoh: {VEHICLES} vehicles' {args.objects}-object highway proposals in "
        f"turn, each with the default {BUDGET_S * 1000:g} ms budget, after {WARM_UP_S:g} s at {VEHICLES * 5} "
        "proposals/s so that the workers have timed their batches.",
        "",
        "Decided = a verdict from the rules; in time = decided within the budget (latency from submission to the "
        "end of its batch); shed = answered at once without a decision, for the monitor to send a fail-safe "
        "(too little budget left, or shed under overload so that younger proposals are decided in time). "
        "Latencies are those of the decided proposals.",
        "",
        "| workers | proposals/s | sent | answered | decided | in time | shed | p50 ms | p99 ms | max ms |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows,
    ])
    if not args.no_docs:
        write_section("worker", body)
    print(body)


if __name__ == "__main__":
    relaunch()  # on jemalloc where the machine has it, as the `discern` command runs (monitor/allocator.py)
    main()
