"""Interleaved timing: every contender of a comparison in the same rounds, minimum per contender.

Usage: ``best = compare({"name": fn, ...}, rounds=7)`` returns seconds per call of each ``fn()``;
``SPREAD`` collects, for every contender timed, its median round / its best round (the noise).

Each contender is calibrated once to ``number`` calls per round so that one round takes at least
``MIN_ROUND`` seconds (``timeit`` with the garbage collector off). Then ``rounds`` rounds run the
contenders one after the other, the order rotated every round, and each contender's figure is its
fastest round: noise (another process, a frequency change) only ever adds time, and because the
contenders alternate within seconds of each other, a slow minute slows all of them alike.
"""

from __future__ import annotations

import math
import statistics
import timeit
from collections.abc import Callable

MIN_ROUND = 0.02  # [s] shortest round
SPREAD: list[float] = []  # median round / best round of every contender timed, for the report


def calibrate(timer: timeit.Timer, min_round: float = MIN_ROUND) -> int:
    """Calls per round so that one round takes at least ``min_round`` seconds."""
    number = 1
    while True:
        t = timer.timeit(number)
        if t >= min_round:
            return number
        number = max(2 * number, math.ceil(number * 1.2 * min_round / max(t, 1e-9)))


def compare(contenders: dict[str, Callable[[], object]], rounds: int,
            min_round: float = MIN_ROUND) -> dict[str, float]:
    """Seconds per call of each contender, the minimum over interleaved rounds."""
    timers = {k: timeit.Timer(fn) for k, fn in contenders.items()}
    for fn in contenders.values():  # warm up (first calls may compile or fill caches)
        fn()
    numbers = {k: calibrate(t, min_round) for k, t in timers.items()}
    names = list(timers)
    samples: dict = {k: [] for k in names}
    for r in range(rounds):
        s = r % len(names)
        for k in names[s:] + names[:s]:
            samples[k].append(timers[k].timeit(numbers[k]) / numbers[k])
    SPREAD.extend(statistics.median(v) / min(v) for v in samples.values())
    return {k: min(v) for k, v in samples.items()}
