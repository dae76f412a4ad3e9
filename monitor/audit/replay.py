"""Replay: re-decide every logged frame with the current (or another) rules catalog.

A regression check for rule edits: each frame the rules judged is decided
again from its logged scene, proposed action and rebuilt history, and every
frame whose decision or executed action would change is reported with both
justifications. Fail-safe verdicts and refused inputs were not decided by the
rules and are counted, not replayed.

Frames are solved in batches, many in one grounding (Reasoner.solve_facts).
Each frame is first only solved: a verdict's decision and action follow from
the proposed action, the shadow flag, the permitted set and the action that
replaces a forbidden proposal (Reasoner.decide), and the logged verdict carries
them all, so when the solved sets, the recommendation and an override's
replacement equal the logged ones the decision cannot have changed and no
proof is built. Otherwise the frame is decided in full, and a changed one is
explained with its whole justification tree. `compare_rules` decides every
frame in full, to also find frames that keep their decision but cite other
rules.

Work is split into runs of consecutive files (frames.plan_tasks) and, with
several workers, each run by vehicle: a shard reads the whole run but decodes,
pairs, rebuilds the history of and solves only its own vehicles' frames.
Identical frames are solved once per worker (a vehicle stopped at a light
repeats itself): the content key is the frame's facts, all the solver sees of
the scene, the proposal and the history (Reasoner.frame_facts), and the shadow
flag. Frame ids and clock times are not among the facts, only time differences.
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import time
import zlib
from collections import Counter, OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

from discern.monitor.config import MonitorConfig, check_number
from discern.monitor.log import FileRecovery, RecoveryReport, log_files, log_metadata
from discern.rules.catalog import Catalog, catalog_dirs, load_catalog, load_driving_rules
from discern.rules.engine import JURISDICTIONS, Reasoner, Request, jurisdiction_pack
from discern.rules.facts import Params
from discern.rules.scene import Action
from discern.rules.verdict import Decision, Verdict
from discern.sanity import WindowConfig, default_providers

from .aggregate import Filters, scenario_kind
from .frames import LEAD_IN_SLACK_S, Frame, FrameTask, PairingCounts, plan_tasks, read_frames
from .parallel import run_jobs
from .runs import RunGap, gaps

BATCH = 96  # distinct frames grounded together: the per-rule cost is paid once per batch (rules/batch.py)
CACHE_LIMIT = 100_000  # decided frames kept per worker for reuse, the least recently used dropped first


@dataclass
class Solved:
    """What one distinct frame came to under the replayed rules; the full outcome only once needed."""

    permitted: frozenset[Action]
    recommended: Optional[Action]
    replacement: Optional[Action]  # what an override executes: not always the recommendation
    outcome: Optional["Outcome"] = None


@dataclass(frozen=True)
class Outcome:
    decision: str
    action: str
    rules: tuple[str, ...]

    @classmethod
    def of(cls, verdict: Verdict) -> "Outcome":
        return cls(verdict.decision.value, verdict.action.value, tuple(verdict.rules))

    def describe(self) -> str:
        return f"{self.decision} {self.action}"


@dataclass
class Change:
    time_ns: int
    vehicle: str
    file: str
    frame_id: Optional[int]
    scenario: str
    recorded: dict  # the verdict as logged (JSON)
    replayed: dict  # the verdict with the replay's catalog, full justification tree

    @property
    def transition(self) -> str:
        def side(v: dict) -> str:
            return f"{v['decision']} {v['action']}"

        return f"{self.recorded.get('proposed')}: {side(self.recorded)} -> {side(self.replayed)}"


@dataclass
class ReplayTally:
    frames: int = 0  # frames replayed
    solved: int = 0  # of which the reasoner ran
    reused: int = 0  # of which a copy was solved before (same content)
    decided: int = 0  # frames decided in full (the solved sets differed from the log's, or compare_rules)
    changes: list[Change] = field(default_factory=list)
    rules_only: int = 0  # same decision and action, other rule ids
    rules_only_examples: Counter = field(default_factory=Counter)  # (recorded rules, replayed rules)
    transitions: Counter = field(default_factory=Counter)
    skipped_failsafe: int = 0  # fail-safe verdicts: the rules did not decide them
    skipped_refused: int = 0  # verdicts without a logged proposal (refused or still queued): no scene to replay
    solve_s: float = 0.0  # worker wall time spent in the reasoner
    cpu_s: float = 0.0  # worker CPU time for the whole job (reading included)
    counts: PairingCounts = field(default_factory=PairingCounts)
    recovery: list[FileRecovery] = field(default_factory=list)
    gaps: list[RunGap] = field(default_factory=list)  # the runs the files leave incomplete, once all are merged

    def merge(self, other: "ReplayTally") -> None:
        for name in (
            "frames",
            "solved",
            "reused",
            "decided",
            "rules_only",
            "skipped_failsafe",
            "skipped_refused",
            "solve_s",
            "cpu_s",
        ):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.changes.extend(other.changes)
        self.rules_only_examples.update(other.rules_only_examples)
        self.transitions.update(other.transitions)
        self.counts.merge(other.counts)
        mine = {f.path: f for f in self.recovery}
        for share in other.recovery:  # each shard read its vehicles' records of the file
            if share.path in mine:
                mine[share.path].add_share(share)
            else:
                self.recovery.append(share)

    @property
    def unanswered(self) -> int:
        return max(0, self.counts.unanswered - self.counts.carried)


@dataclass
class ReplayResult:
    tally: ReplayTally
    catalog: "ReplayCatalog"
    wall_s: float
    workers: int
    compare_rules: bool = False
    filters: Filters = field(default_factory=Filters)
    window_s: float = MonitorConfig.window_s  # the history window the frames were decided with

    @property
    def frames_per_s(self) -> float:
        return self.tally.frames / self.wall_s if self.wall_s > 0 else 0.0


@dataclass(frozen=True)
class ReplayJob:
    task: FrameTask
    shard: int
    shards: int
    filters: Filters
    window_s: float
    caller_pid: int  # the process that asked for the replay: one worker runs the jobs in it
    compare_rules: bool = False


class _Worker:
    """Per-process state: one Reasoner and the decided frames."""

    def __init__(self, catalog: "ReplayCatalog", window_s: float):
        self.catalog = catalog
        self.window_s = window_s
        # the sanity layer sees the window the frames' histories were rebuilt with, as the monitor's did
        window = default_providers(WindowConfig(seconds=window_s))
        self.reasoner = Reasoner(catalog=catalog.load(), params=Params(**dict(catalog.params)),
                                 jurisdiction=catalog.jurisdiction, providers=window)
        self.solved: OrderedDict[bytes, Solved] = OrderedDict()
        self.explained: OrderedDict[bytes, Verdict] = OrderedDict()  # changed frames, with their full tree

    def key(self, facts: str, shadow: bool) -> bytes:
        """The frame's content: what the solver sees of it, and whether the verdict was to be enforced."""
        return hashlib.blake2b(f"{int(shadow)}|{facts}".encode(), digest_size=16).digest()


_worker: Optional[_Worker] = None


def _init_worker(catalog: Optional["ReplayCatalog"], window_s: Optional[float] = None) -> None:
    """Load the rules, unless this process already holds them (a forked worker inherits the parent's)."""
    global _worker
    if catalog is None:
        _worker = None
    elif _worker is None or _worker.catalog != catalog or _worker.window_s != window_s:
        _worker = _Worker(catalog, window_s)


def replay_task(job: ReplayJob) -> ReplayTally:
    """Re-decide the frames of this job's files and shard (in a worker process, or the caller's with one worker).

    The cyclic garbage collector is off for the job: it found nothing to free
    here (a collection after a job finds 0 objects, measured) but rescanned the
    worker's caches of scenes again and again, about 0.3 ms a frame, a fifth of
    the replay. What the job leaves in a worker process is frozen: long-lived caches,
    never rescanned. The caller's heap is not: frozen objects are never collected, in
    a program that goes on after the replay.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        return _replay_task(job)
    finally:
        if os.getpid() != job.caller_pid:
            gc.freeze()
        if enabled:
            gc.enable()


def _replay_task(job: ReplayJob) -> ReplayTally:
    worker = _worker
    cpu_start = time.process_time()
    report = RecoveryReport()
    keep = None if job.shards == 1 else lambda vehicle: vehicle_shard(vehicle, job.shards) == job.shard
    frames, pairing = read_frames(job.task, report, window_s=job.window_s, keep=keep, counted=job.filters.selects)
    tally = ReplayTally()
    chunk: list[tuple[Frame, bytes, str]] = []  # decided as the frames stream by: memory stays flat on long logs
    for frame in frames:
        if frame.lead_in or not job.filters.frame_selected(frame):
            continue
        recorded = frame.verdict
        if frame.proposal is None:
            tally.skipped_refused += 1
            continue
        if recorded.failsafe or frame.history is None:
            tally.skipped_failsafe += 1
            continue
        facts = worker.reasoner.frame_facts(frame.proposal.scene, frame.proposal.action, frame.history)
        chunk.append((frame, worker.key(facts, recorded.shadow), facts))
        if len(chunk) == BATCH:
            _replay_chunk(worker, chunk, job.compare_rules, tally)
            chunk = []
    _replay_chunk(worker, chunk, job.compare_rules, tally)
    tally.counts = pairing.counts  # of this shard's vehicles: the shards' counts add up to the file's
    tally.recovery = report.files
    tally.cpu_s = time.process_time() - cpu_start
    return tally


def vehicle_shard(vehicle: Optional[str], shards: int) -> int:
    """The shard a vehicle's frames go to (records of no vehicle: shard 0); stable across processes."""
    return zlib.crc32(vehicle.encode()) % shards if vehicle else 0


def _replay_chunk(
    worker: _Worker, chunk: list[tuple[Frame, bytes, str]], compare_rules: bool, tally: ReplayTally
) -> None:
    known = _solve_new(worker, chunk, compare_rules, tally)
    for frame, key, _ in chunk:
        _compare(worker, frame, key, known[key], tally)


def _solve_new(
    worker: _Worker, chunk: list[tuple[Frame, bytes, str]], compare_rules: bool, tally: ReplayTally
) -> dict[bytes, Solved]:
    """Solve the chunk's frames not solved before, all in one grounding (Reasoner.solve_facts); what each key came to.

    The chunk's entries are held here, not looked up in the cache again: caching
    the new ones evicts the least recently used, which may be one the chunk needs.
    """
    known: dict[bytes, Solved] = {}
    pending: dict[bytes, tuple[Frame, str]] = {}
    for frame, key, facts in chunk:
        if key in known or key in pending:
            continue
        hit = worker.solved.get(key)
        if hit is None:
            pending[key] = (frame, facts)
        else:
            worker.solved.move_to_end(key)  # in use: a frame that keeps repeating stays cached
            known[key] = hit
    tally.frames += len(chunk)
    tally.solved += len(pending)
    tally.reused += len(chunk) - len(pending)
    if not pending:
        return known
    start = time.perf_counter()
    frames = [frame for frame, _ in pending.values()]
    texts = [facts for _, facts in pending.values()]
    if compare_rules:
        verdicts = worker.reasoner.decide_many(
            [Request(f.proposal.scene, f.proposal.action, f.history, shadow=f.verdict.shadow) for f in frames], texts
        )
        results = [Solved(frozenset(v.permitted), v.recommended, None, Outcome.of(v)) for v in verdicts]
        tally.decided += len(results)
    else:
        solved = worker.reasoner.solve_facts(texts, [f.proposal.action for f in frames])
        results = [Solved(frozenset(s.permitted), s.recommended, s.replacement) for s in solved]
    tally.solve_s += time.perf_counter() - start
    for key, result in zip(pending, results):
        known[key] = result
        _remember(worker.solved, key, result)
    return known


def _compare(worker: _Worker, frame: Frame, key: bytes, known: Solved, tally: ReplayTally) -> None:
    """Count the frame as unchanged, changed (with both justifications) or citing other rules."""
    recorded, scene, action = frame.verdict, frame.proposal.scene, frame.proposal.action
    if known.outcome is None:
        if (known.permitted == frozenset(recorded.permitted) and known.recommended == recorded.recommended
                and (recorded.decision is not Decision.override or recorded.action is known.replacement)):
            return  # same permitted set, recommendation and replacement: the same decision and action
        start = time.perf_counter()
        known.outcome = Outcome.of(worker.reasoner.decide(scene, action, history=frame.history, shadow=recorded.shadow))
        tally.solve_s += time.perf_counter() - start
        tally.decided += 1
    outcome, before = known.outcome, Outcome.of(recorded)
    if (outcome.decision, outcome.action) != (before.decision, before.action):
        tally.changes.append(_change(worker, key, frame))
        tally.transitions[f"{action.value}: {before.describe()} -> {outcome.describe()}"] += 1
    elif outcome.rules != before.rules:
        tally.rules_only += 1
        tally.rules_only_examples[(", ".join(before.rules), ", ".join(outcome.rules))] += 1


def _remember(cache: OrderedDict, key: bytes, value) -> None:
    cache[key] = value
    if len(cache) > CACHE_LIMIT:
        cache.popitem(last=False)


def _change(worker: _Worker, key: bytes, frame) -> Change:
    """The changed frame, decided again with the full justification tree (once per distinct frame)."""
    scene = frame.proposal.scene
    explained = worker.explained.get(key)
    if explained is None:
        explained = worker.reasoner.decide(
            scene, frame.proposal.action, history=frame.history, explain=True, shadow=frame.verdict.shadow
        )
        _remember(worker.explained, key, explained)
    replayed = explained.model_dump(mode="json")
    # the frame's own identity; no latency: this decision was not made by a monitor in time
    replayed.update(frame_id=scene.frame_id, timestamp=scene.timestamp, vehicle=frame.vehicle, latency_ms=None)
    return Change(
        time_ns=frame.log_time_ns,
        vehicle=frame.vehicle,
        file=frame.file,
        frame_id=scene.frame_id,
        scenario=scenario_kind(scene),
        recorded=frame.verdict.model_dump(mode="json"),
        replayed=replayed,
    )


@dataclass(frozen=True)
class ReplayCatalog:
    """The rules to replay with: the shipped ones as the monitor loads them, edited driving rules, or rules of
    one's own beside either (as `discern check --rules / --add-rules`).

    Given driving-rules directories replace rules/catalog; the shipped sanity
    rules and the jurisdiction's pack stay, so an edited copy of rules/catalog
    is compared on equal terms.
    """

    rules: tuple[str, ...] = ()  # driving-rules directories in place of rules/catalog; none: the shipped ones
    jurisdiction: str = "us"
    params: tuple[tuple[str, float], ...] = ()  # reasoning parameters (rules.facts.Params) other than the defaults
    added: tuple[str, ...] = ()  # driving-rules directories loaded beside `rules` (or the shipped ones)

    @classmethod
    def of(cls, rules: Optional[Sequence[str]] = None, jurisdiction: str = "us",
           params: Optional[dict[str, float]] = None, added: Optional[Sequence[str]] = None) -> "ReplayCatalog":
        """A directory named twice (`--rules D --rules D/`) is loaded once, where it first appears."""
        once: dict[Path, str] = {}
        for d in rules or ():
            once.setdefault(Path(d).resolve(), str(d))
        beside: dict[Path, str] = {}
        for d in added or ():
            if Path(d).resolve() not in once:
                beside.setdefault(Path(d).resolve(), str(d))
        jurisdiction_pack(jurisdiction)  # an unknown name fails here, naming the known ones
        return cls(tuple(once.values()), jurisdiction, tuple(sorted((params or {}).items())), tuple(beside.values()))

    @property
    def dirs(self) -> tuple[str, ...]:
        """Every rules directory loaded: the driving rules given (or the shipped ones), those added, then the
        sanity rules."""
        driving = self.rules or (str(catalog_dirs()[0]),)
        given = {Path(d).resolve() for d in driving + self.added}
        return driving + self.added + tuple(str(d) for d in catalog_dirs()[1:] if d.resolve() not in given)

    def load(self) -> Catalog:
        """Raises CatalogError naming a directory that is missing, unreadable or defines no driving rules."""
        pack = [jurisdiction_pack(self.jurisdiction)]
        if self.rules or self.added:
            driving = [Path(d) for d in self.rules] or [catalog_dirs()[0]]
            return load_driving_rules(driving + [Path(d) for d in self.added], extra_files=pack)
        return load_catalog(extra_files=pack)

    def describe(self) -> str:
        params = "".join(f", {name}={value:g}" for name, value in self.params)
        return f"{', '.join(self.dirs)} ({self.jurisdiction} rules{params})"


@dataclass(frozen=True)
class RecordedSetup:
    """What the logs' verdicts were decided with, as the writer recorded it (None: not recorded, the defaults)."""

    params: dict[str, float]
    jurisdiction: Optional[str] = None
    window_s: Optional[float] = None
    catalog: Optional[str] = None  # the digest of the rules that decided (rules.catalog.catalog_digest)
    code: tuple[str, ...] = ()  # the digests of the reasoning code that decided (rules.code_digest), as recorded


def recorded_setup(paths: Sequence[str]) -> RecordedSetup:
    """The reasoning parameters, rule pack and history window of the logs' monitor (the writer's metadata).

    A replay with another setup would report every decision it changes as a rule change. Files without the
    writer's metadata (empty, foreign, cut before it) say nothing and are passed over. Raises ValueError naming
    the files when they disagree (each setup is its own replay) or a recorded value this version cannot use.
    """
    first: dict[tuple[str, str, str, str], str] = {}  # the setup as recorded -> the first file that has it
    code: list[str] = []  # code may differ between files (a monitor updated): the replay says so, and goes on
    for path in log_files(paths):
        metadata = log_metadata(path)
        if metadata:
            if metadata.get("code") and metadata["code"] not in code:
                code.append(metadata["code"])
            setup = (metadata.get("params", "{}"), metadata.get("jurisdiction", ""), metadata.get("window_s", ""),
                     metadata.get("catalog", ""))
            first.setdefault(setup, str(path))
    if len(first) > 1:
        shown = "; ".join(f"{path}: params {p}, jurisdiction {j or '-'}, window {w or '-'} s, catalog {c or '-'}"
                          for (p, j, w, c), path in first.items())
        raise ValueError(f"the logs were decided with different settings ({shown}): replay them apart")
    if not first:
        return RecordedSetup({})
    (params, jurisdiction, window, catalog), path = next(iter(first.items()))
    try:
        pairs = [f"{name}={value}" for name, value in json.loads(params).items()]
    except (ValueError, AttributeError, TypeError):
        raise ValueError(f"{path}: unreadable reasoning parameters {params!r}") from None
    values, problems = Params.overrides(pairs)
    if problems:
        raise ValueError(f"{path}: recorded reasoning parameters this version cannot use: {'; '.join(problems)}")
    if jurisdiction and jurisdiction not in JURISDICTIONS:
        raise ValueError(f"{path}: recorded jurisdiction {jurisdiction!r} is none this version knows "
                         f"({', '.join(JURISDICTIONS)})")
    try:
        window_s = float(window) if window else None
        if window_s is not None:
            check_number("window_s", window_s, 0, unit=" s", above=True)
    except ValueError:
        raise ValueError(f"{path}: unreadable recorded history window {window!r}") from None
    return RecordedSetup(values, jurisdiction or None, window_s, catalog or None, tuple(code))


def replay_logs(
    paths: Sequence[str],
    catalog: Optional[ReplayCatalog] = None,
    filters: Optional[Filters] = None,
    workers: int = 1,
    window_s: Optional[float] = None,
    compare_rules: bool = False,
) -> ReplayResult:
    """Replay every file; raises CatalogError (from load_catalog) for a broken rules directory."""
    window = window_s if window_s is not None else MonitorConfig().window_s
    catalog = catalog if catalog is not None else ReplayCatalog.of()
    filters = filters if filters is not None else Filters()
    start = time.perf_counter()
    _init_worker(catalog, window)  # a broken catalog fails here, once; forked workers inherit the loaded rules
    try:
        tasks = plan_tasks(list(paths), parts=max(1, workers), lead_in_s=window + LEAD_IN_SLACK_S)
        shards = max(1, workers)  # every run of files split by vehicle: even shares, whatever the file sizes
        jobs = [
            ReplayJob(task, shard, shards, filters, window, os.getpid(), compare_rules)
            for task in tasks
            for shard in range(shards)
        ]
        total = ReplayTally()
        for tally in run_jobs(replay_task, jobs, workers, _init_worker, (catalog, window)):
            total.merge(tally)
    finally:
        _init_worker(None)  # drop the rules and caches, or a later fork inherits them
    total.gaps = gaps(list(paths), total.counts.last_status)
    wall = time.perf_counter() - start
    total.changes.sort(key=lambda c: (c.time_ns, c.vehicle))
    return ReplayResult(total, catalog, wall, max(1, min(workers, len(jobs))), compare_rules, filters, window)
