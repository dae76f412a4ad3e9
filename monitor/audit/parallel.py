"""Run audit jobs on a pool of worker processes, or in this process when one worker is asked for.

clingo holds the GIL while it grounds, so only processes scale. Workers fork
when this process runs a single thread (they inherit the loaded modules,
saving about half a second each) and spawn otherwise, because forking a
threaded process can copy a lock in its held state.
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterator, Optional, TypeVar

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def run_jobs(
    fn: Callable[[T], R],
    jobs: list[T],
    workers: int,
    initializer: Optional[Callable[..., None]] = None,
    initargs: tuple = (),
) -> Iterator[R]:
    """fn(job) for every job, results in job order."""
    workers = max(1, min(workers, len(jobs)))
    if workers == 1:
        if initializer is not None:
            initializer(*initargs)
        for job in jobs:
            yield fn(job)
        return
    methods = multiprocessing.get_all_start_methods()
    method = "fork" if "fork" in methods and threading.active_count() == 1 else "spawn"
    if method == "fork":
        # The children would otherwise rescan (and so copy) every object they inherit at their first
        # collection: up to a second of start-up after a big parent heap, measured. Python's own advice.
        gc.freeze()
    try:
        with ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context(method),
            initializer=initializer,
            initargs=initargs,
        ) as pool:
            yield from pool.map(fn, jobs)
    finally:
        if method == "fork":
            gc.unfreeze()
