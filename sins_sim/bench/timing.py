"""Timing protocol: medians of repeated calls after an untimed first call, same-run ratios."""

from __future__ import annotations

import statistics
import time

__all__ = ["CLOCKS", "median_time", "median_ratio", "check"]

#: ``cpu``: CPU time of the calling thread (one core's work, blind to other processes);
#: ``wall``: elapsed time.
CLOCKS = {"cpu": time.thread_time, "wall": time.perf_counter}


def median_time(fn, repeats: int, clock="cpu") -> float:
    """Median of ``repeats`` timed calls of ``fn`` after one untimed call (seconds).

    ``clock``: ``"cpu"`` (thread CPU time), ``"wall"``, or a callable returning seconds.
    """
    clock = CLOCKS[clock] if isinstance(clock, str) else clock
    fn()
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return statistics.median(times)


def median_ratio(fn, n_fn: int, base_fn, n_base: int, repeats: int, clock="cpu"):
    """Per-sample cost ratio of ``fn`` (``n_fn`` samples) to ``base_fn`` (``n_base``), interleaved.

    One untimed call of each, then ``repeats`` pairs timed back to back; the
    ratio is the median of the pairs' ratios, so a change in the machine's
    load during the measurement cancels. Returns ``(ratio, ns_fn, ns_base)``
    with the medians per sample in ns.
    """
    clock = CLOCKS[clock] if isinstance(clock, str) else clock
    fn()
    base_fn()
    ta, tb = [], []
    for _ in range(repeats):
        t0 = clock()
        fn()
        t1 = clock()
        base_fn()
        t2 = clock()
        ta.append((t1 - t0) / n_fn)
        tb.append((t2 - t1) / n_base)
    ratio = statistics.median([a / b for a, b in zip(ta, tb)])
    return ratio, statistics.median(ta) * 1e9, statistics.median(tb) * 1e9


def check(cond: bool, what: str) -> None:
    if not cond:
        raise RuntimeError(f"bench: result check failed: {what}")
