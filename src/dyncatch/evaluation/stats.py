"""Summaries of episode outcomes with 95 % confidence intervals."""

from __future__ import annotations

import math

import numpy as np

_Z95 = 1.959963984540054


def wilson_ci95(successes: int, n: int) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (well-behaved at 0 and 1).

    At 0 successes the lower bound is exactly 0 and at ``n`` the upper exactly 1: the
    formula's ``centre - half`` is 0 there in exact arithmetic, and its rounding (1.7e-18 at
    0 of 200) would give an interval that excludes its own estimate."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + _Z95**2 / n
    centre = (p + _Z95**2 / (2 * n)) / denom
    half = _Z95 * math.sqrt(p * (1 - p) / n + _Z95**2 / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return (lo, hi)


def summarize(outcome: dict) -> dict:
    """Success rate (with Wilson CI) and mean catch time (failures count as the limit)."""
    success = np.asarray(outcome["success"], bool)
    times = np.asarray(outcome["catch_time_s"], float)
    n, k = success.size, int(success.sum())
    return {
        "episodes": n,
        "success_rate": k / n if n else float("nan"),
        "success_ci95": list(wilson_ci95(k, n)),
        "catch_time_s": float(times.mean()) if n else float("nan"),
    }
