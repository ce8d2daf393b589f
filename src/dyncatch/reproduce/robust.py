"""rliable's aggregate metrics over a run's cells, seeds as the unit and behaviours as the
strata: the interquartile mean and the mean with stratified bootstrap intervals, and the
probability that one method's seed beats another's (Agarwal et al., 2021)."""

from __future__ import annotations

import numpy as np

from dyncatch.evaluation.intervals import (
    iqm,
    probability_of_improvement,
    stratified_bootstrap_ci,
)


def _scores(cells: list[dict], method: str, speed) -> np.ndarray | None:
    """(seeds, behaviours) success of ``method`` at ``speed``, behaviours in sorted order;
    None unless every behaviour has the same 2+ seeds."""
    per = {
        c["behavior"]: c["per_seed_success"]
        for c in cells
        if c["method"] == method and c["speed_mps"] == speed
    }
    if not per or len({len(p) for p in per.values()}) != 1 or len(next(iter(per.values()))) < 2:
        return None
    return np.asarray([per[b] for b in sorted(per)], float).T


def robust_summary(cells: list[dict], speeds, methods, reps: int = 10_000) -> list[dict]:
    """Per speed and method: the mean and the interquartile mean of success over all
    (seed, behaviour) scores, each with a stratified bootstrap 95 % interval."""
    out = []
    for speed in speeds:
        for method in methods:
            x = _scores(cells, method, speed)
            if x is None:
                continue
            mean, mean_ci = stratified_bootstrap_ci(x, np.mean, reps)
            mid, mid_ci = stratified_bootstrap_ci(x, iqm, reps)
            out.append(
                {
                    "method": method,
                    "speed_mps": speed,
                    "seeds": x.shape[0],
                    "behaviors": x.shape[1],
                    "mean": mean,
                    "mean_ci95": list(mean_ci),
                    "iqm": mid,
                    "iqm_ci95": list(mid_ci),
                }
            )
    return out


def improvement_probabilities(cells: list[dict], speeds, claims, reps: int = 2_000) -> list[dict]:
    """Per speed and claim ``(winner, loser)``: P(a seed of the winner beats one of the
    loser), averaged over behaviours, with a stratified bootstrap 95 % interval."""
    out = []
    for speed in speeds:
        for hi, lo in claims:
            a, b = _scores(cells, hi, speed), _scores(cells, lo, speed)
            same = {c["behavior"] for c in cells if c["method"] == hi and c["speed_mps"] == speed}
            other = {c["behavior"] for c in cells if c["method"] == lo and c["speed_mps"] == speed}
            if a is None or b is None or same != other:
                continue
            p, ci = probability_of_improvement(a, b, reps)
            out.append(
                {"claim": f"{hi} > {lo}", "speed_mps": speed, "p_improvement": p, "ci95": list(ci)}
            )
    return out
