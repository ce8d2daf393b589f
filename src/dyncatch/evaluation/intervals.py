"""Inference with seeds as the unit: t-intervals, Welch differences, Holm's correction, the
smallest difference a run resolves and the seeds a difference needs, and stratified bootstrap
intervals of rliable's aggregate metrics.

Quantiles come from scipy (never a table), the interquartile mean and the probability of
improvement from rliable (Agarwal et al., 2021). The stratified bootstrap is scipy's
``bootstrap`` over one sample per task (behaviour), which resamples the seeds of each task
independently, as rliable's ``StratifiedBootstrap`` does; scipy's takes a seeded generator,
which rliable cannot hand to arch >= 8.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.stats
from rliable import metrics

CONFIDENCE = 0.95
"""Two-sided confidence of every interval, and 1 - alpha of every test."""


def t_quantile(df: float, confidence: float = CONFIDENCE) -> float:
    """The two-sided Student-t quantile, e.g. 2.228 at df 10 and 95 %."""
    return float(scipy.stats.t.ppf(0.5 + confidence / 2, df))


def mean_ci(
    values: Sequence[float], confidence: float = CONFIDENCE
) -> tuple[float, tuple[float, float] | None]:
    """Mean and t-interval over seeds (None with a single seed)."""
    x = np.asarray(values, float)
    m = float(x.mean())
    if x.size < 2:
        return m, None
    half = t_quantile(x.size - 1, confidence) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return m, (m - half, m + half)


def welch_df(var_a: float, n_a: int, var_b: float, n_b: int) -> float:
    """Welch-Satterthwaite degrees of freedom of a difference of two means from sample
    variances; ``n_a + n_b - 2`` when both variances are 0 (no spread to weigh)."""
    ua, ub = var_a / n_a, var_b / n_b
    denom = ua**2 / (n_a - 1) + ub**2 / (n_b - 1)
    return float((ua + ub) ** 2 / denom) if denom > 0 else float(n_a + n_b - 2)


@dataclass(frozen=True)
class Difference:
    """``mean(a) - mean(b)`` with its interval and two-sided test."""

    difference: float
    half_width: float
    """Half-width of the two-sided interval: the smallest difference this run resolves."""
    df: float
    """Degrees of freedom of the t-quantile (inf for a normal interval)."""
    p_value: float
    """Two-sided p-value of 'no difference'."""

    @property
    def ci(self) -> tuple[float, float]:
        return (self.difference - self.half_width, self.difference + self.half_width)


def _two_sided(d: float, se: float, df: float, confidence: float) -> Difference:
    # scipy's t at df = inf is the normal.
    if se == 0:
        return Difference(d, 0.0, df, 1.0 if d == 0 else 0.0)
    p = 2 * float(scipy.stats.t.sf(abs(d) / se, df))
    return Difference(d, t_quantile(df, confidence) * se, df, p)


def welch(a: Sequence[float], b: Sequence[float], confidence: float = CONFIDENCE) -> Difference:
    """Welch's t-interval and test of ``mean(a) - mean(b)`` over seeds (2+ seeds each)."""
    xa, xb = np.asarray(a, float), np.asarray(b, float)
    if xa.size < 2 or xb.size < 2:
        raise ValueError(f"Welch needs 2+ seeds on each side, got {xa.size} and {xb.size}")
    va, vb = float(xa.var(ddof=1)), float(xb.var(ddof=1))
    se = math.sqrt(va / xa.size + vb / xb.size)
    df = welch_df(va, xa.size, vb, xb.size)
    return _two_sided(float(xa.mean() - xb.mean()), se, df, confidence)


def proportion_difference(
    pa: float, na: int, pb: float, nb: int, confidence: float = CONFIDENCE
) -> Difference:
    """Normal interval and test of ``pa - pb`` from episode counts (a single seed each)."""
    se = math.sqrt(max(pa * (1 - pa), 1e-12) / na + max(pb * (1 - pb), 1e-12) / nb)
    return _two_sided(pa - pb, se, math.inf, confidence)


def holm(p_values: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values (family-wise error), in the input's order:
    the i-th smallest p times (m - i + 1), made non-decreasing, capped at 1."""
    p = np.asarray(p_values, float)
    order = np.argsort(p, kind="stable")
    scaled = p[order] * (p.size - np.arange(p.size))
    adjusted = np.empty_like(p)
    adjusted[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return adjusted


def resolvable_difference(
    sd_a: float, n_a: int, sd_b: float, n_b: int, confidence: float = CONFIDENCE
) -> float:
    """The half-width of the Welch interval of a difference at these seeds and spreads: a
    true difference smaller than this cannot exclude 0 at this run's size."""
    va, vb = sd_a**2, sd_b**2
    return t_quantile(welch_df(va, n_a, vb, n_b), confidence) * math.sqrt(va / n_a + vb / n_b)


def seeds_for_power(
    difference: float,
    sd_a: float,
    sd_b: float,
    power: float = 0.8,
    confidence: float = CONFIDENCE,
    max_seeds: int = 10_000,
) -> int:
    """Seeds per method for a two-sided Welch test at ``1 - confidence`` to detect
    ``difference`` with probability ``power``: the least n with
    n >= (t_{1-alpha/2, df} + t_{power, df})^2 (sd_a^2 + sd_b^2) / difference^2,
    df the Welch-Satterthwaite df at n seeds each (the normal approximation's z's, 1.960
    and 0.842, give a slightly smaller n)."""
    if difference == 0:
        raise ValueError("a difference of 0 needs infinitely many seeds")
    spread = (sd_a**2 + sd_b**2) / difference**2
    for n in range(2, max_seeds + 1):
        df = welch_df(sd_a**2, n, sd_b**2, n)
        q = t_quantile(df, confidence) + float(scipy.stats.t.ppf(power, df))
        if n >= q**2 * spread:
            return n
    raise ValueError(f"more than {max_seeds} seeds per method")


def iqm(scores: np.ndarray) -> float:
    """rliable's interquartile mean of (seeds, tasks) scores (the middle 50 % of all)."""
    return float(metrics.aggregate_iqm(np.asarray(scores, float)))


def stratified_bootstrap_ci(
    scores: np.ndarray,
    statistic: Callable[[np.ndarray], float],
    reps: int = 10_000,
    seed: int = 0,
    confidence: float = CONFIDENCE,
) -> tuple[float, tuple[float, float]]:
    """(statistic, percentile interval) of (seeds, tasks) ``scores``; each task's seeds are
    resampled with replacement independently (stratified), the statistic recomputed on the
    (seeds, tasks) resample."""
    x = np.asarray(scores, float)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"scores must be (seeds >= 2, tasks), got shape {x.shape}")
    res = scipy.stats.bootstrap(
        tuple(x.T),
        lambda *tasks: statistic(np.stack(tasks, axis=-1)),
        n_resamples=reps,
        vectorized=False,
        method="percentile",
        confidence_level=confidence,
        rng=np.random.default_rng(seed),
    )
    lo, hi = res.confidence_interval
    return statistic(x), (float(lo), float(hi))


def probability_of_improvement(
    a: np.ndarray, b: np.ndarray, reps: int = 2_000, seed: int = 0
) -> tuple[float, tuple[float, float]]:
    """rliable's P(a > b) (Mann-Whitney's, averaged over tasks) of (seeds, tasks) scores with
    a stratified bootstrap interval over both methods' seeds."""
    xa, xb = np.asarray(a, float), np.asarray(b, float)
    point = float(metrics.probability_of_improvement(xa, xb))
    rng = np.random.default_rng(seed)
    draws = np.empty(reps)
    for r in range(reps):
        ia = rng.integers(0, xa.shape[0], xa.shape)
        ib = rng.integers(0, xb.shape[0], xb.shape)
        ra = np.take_along_axis(xa, ia, axis=0)
        rb = np.take_along_axis(xb, ib, axis=0)
        draws[r] = metrics.probability_of_improvement(ra, rb)
    tail = 50 * (1 - CONFIDENCE)
    lo, hi = np.percentile(draws, [tail, 100 - tail])
    return point, (float(lo), float(hi))
