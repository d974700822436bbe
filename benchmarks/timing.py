"""Timing helper shared by the benchmark scripts."""

from __future__ import annotations

import time
from typing import Callable


def best(f: Callable[[], object], repeats: int = 3) -> float:
    """The shortest of `repeats` wall times of `f()` (seconds)."""
    out = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t)
    return out
