"""Health of a running monitor: decision counts and latency, answered on its status key and logged."""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, Field

from discern.rules.scene import SCHEMA_VERSION, Version
from discern.rules.verdict import Decision

LATENCY_SAMPLES = 8192  # percentiles cover the most recent decisions
LOG_FILES_LISTED = 5  # the status names this run's last log files, the one being written last
_DECISION_COUNTER = {Decision.approve.value: "approvals", Decision.veto.value: "vetoes", Decision.override.value: "overrides"}


def percentile(ordered: Sequence[float], q: float) -> float:
    """The q-th percentile (0-100) of sorted values by nearest rank: the least value with at least q% of them at or
    below it, so no more than (100 - q)% lie above a p99 (the p50 of two is the lower).

    A measured value, never interpolated: the status key, the audit and the benchmarks report the same
    figure for the same samples. Until 2026-11-26 it was the value nearest q% of the way from the least to the
    greatest, which put 3 of 273 latencies above a p99 and that p99 under a budget the tail was over.
    """
    rank = math.ceil(round(q * len(ordered) / 100, 9))  # rounded first: 99.9 * 1000 / 100 is 998.99...98 in floats
    return ordered[min(len(ordered), max(rank, 1)) - 1]


class LatencySummary(BaseModel):
    samples: int = 0
    p50_ms: Optional[float] = None
    p90_ms: Optional[float] = None
    p99_ms: Optional[float] = None
    max_ms: Optional[float] = None


class MonitorStatus(BaseModel):
    version: Version = SCHEMA_VERSION
    monitor_id: str
    vehicles_filter: str = Field(description="key chunk of the vehicles this monitor serves")
    uptime_s: float
    budget_ms: float
    proposals: int = 0
    approvals: int = Field(0, description="approvals by the rules")
    vetoes: int = Field(0, description="vetoes by the rules (shadow mode)")
    overrides: int = Field(0, description="overrides by the rules")
    failsafes: int = Field(0, description="verdicts flagged failsafe, bad input included; with the three above, "
                                          "they add up to the proposals")
    errors: int = Field(0, description="proposals refused as bad input")
    errors_by_kind: dict[str, int] = Field(default_factory=dict)
    deadline_misses: int = 0
    internal_errors: int = 0
    late_decisions: int = Field(0, description="decisions that finished after their fail-safe was sent")
    unsent: int = Field(0, description="verdicts counted above that zenoh refused to send (the session closing): "
                                       "logged, but no planner got them; zenoh does not report a querier gone")
    vehicles: int = Field(0, description="vehicles heard from within their window (and budget): those it keeps state for")
    # A monitor that has stopped answering (its watchdog or every worker stuck) counts nothing more: these show it,
    # as a growing count or an oldest one past the budget. Puts that zenoh dropped before they reached the monitor
    # are not among them: it never had them (docs/protocol.md, "What never reaches the monitor").
    open_proposals: int = Field(0, description="proposals received and not answered yet")
    oldest_open_ms: Optional[float] = Field(None, description="how long the oldest open proposal has waited, in ms; "
                                                              "null when none is open")
    latency_ms: LatencySummary = Field(default_factory=LatencySummary)
    log_files: list[str] = Field(default_factory=list, description=f"of this run's last {LOG_FILES_LISTED} log files, as absolute paths, "
                                                                   "those still on disk, the one being written last")
    log_files_opened: int = Field(0, description="log files this run opened, listed or not, deleted or not")
    log_records: int = 0
    log_dropped: int = 0


class StatusCounters:
    """Thread-safe counters fed by every answered proposal."""

    def __init__(self, monitor_id: str, vehicles_filter: str, budget_ms: float):
        self._lock = threading.Lock()
        self._started = time.monotonic()
        self._fixed = dict(monitor_id=monitor_id, vehicles_filter=vehicles_filter, budget_ms=budget_ms)
        self._counts: Counter[str] = Counter()
        self._errors: Counter[str] = Counter()
        self._latency = np.zeros(LATENCY_SAMPLES)
        self._latency_n = 0

    def verdict_sent(self, decision: str, failsafe: bool, latency_ms: float, error_kind: Optional[str]) -> None:
        with self._lock:
            c = self._counts
            c["proposals"] += 1
            # a fail-safe is counted as one, not also as the override or veto it is dressed as: the counts add up
            # to the proposals, as the audit's do
            c["failsafes" if failsafe else _DECISION_COUNTER[decision]] += 1
            if error_kind is not None:
                c["errors"] += 1
                self._errors[error_kind] += 1
            self._latency[self._latency_n % LATENCY_SAMPLES] = latency_ms
            self._latency_n += 1

    def input_refused(self, kind: str) -> None:
        """A proposal found to be bad input whose refusal was not sent: it named no vehicle to answer, or its
        fail-safe went first (at the deadline)."""
        with self._lock:
            self._counts["errors"] += 1
            self._errors[kind] += 1

    def count(self, name: str) -> None:
        with self._lock:
            self._counts[name] += 1

    def counts(self, *names: str) -> tuple[int, ...]:
        with self._lock:
            return tuple(self._counts[name] for name in names)

    def snapshot(self, **extra) -> MonitorStatus:
        with self._lock:
            n = min(self._latency_n, LATENCY_SAMPLES)
            latency = LatencySummary(samples=self._latency_n)
            if n:
                ordered = np.sort(self._latency[:n])
                p50, p90, p99 = (percentile(ordered, q) for q in (50, 90, 99))
                latency = LatencySummary(
                    samples=self._latency_n,
                    p50_ms=round(float(p50), 3),
                    p90_ms=round(float(p90), 3),
                    p99_ms=round(float(p99), 3),
                    max_ms=round(float(ordered[-1]), 3),
                )
            return MonitorStatus(
                **self._fixed,
                uptime_s=round(time.monotonic() - self._started, 3),
                errors_by_kind=dict(self._errors),
                latency_ms=latency,
                **{k: v for k, v in self._counts.items() if k in MonitorStatus.model_fields},
                **extra,
            )
