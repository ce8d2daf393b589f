"""Seeds to means and 95 % confidence intervals, the ordering checks of the paper, and the
benchmark's headroom (the oracle against the best non-oracle method).

Seeds are the unit (``evaluation.intervals``): t-intervals with scipy's quantiles, Welch
differences with Satterthwaite's df. The checks matching a ``PRIMARY_ENDPOINTS`` entry are
judged unadjusted and carry the smallest difference the run resolves; every other check is
secondary, judged on Holm-adjusted p-values over its family (``judge_family``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dyncatch.evaluation.intervals import (
    CONFIDENCE,
    Difference,
    holm,
    mean_ci,
    proportion_difference,
    seeds_for_power,
    welch,
)
from dyncatch.evaluation.stats import wilson_ci95
from dyncatch.reproduce.endpoints import PRIMARY_ENDPOINTS, Endpoint

__all__ = ["mean_ci"]  # re-exported: fig9 summarises its contacts with it


def clip01(ci: tuple[float, float] | None) -> list[float] | None:
    """A success-rate interval cut to [0, 1] (a t-interval over few seeds can overshoot)."""
    return None if ci is None else [max(0.0, ci[0]), min(1.0, ci[1])]


def summarize_cells(rows: list[dict]) -> list[dict]:
    """Group evaluation rows by (behaviour, method, speed) over seeds.

    Success: mean over seeds with a t-interval over seeds when there are 2+ seeds, else the
    Wilson interval of the pooled episodes (also reported as ``pooled_ci95``).
    """
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["behavior"], r["method"], r["speed_mps"]), []).append(r)
    out = []
    for (behavior, method, speed), rs in groups.items():
        succ = [r["success_rate"] for r in rs]
        times = [r["catch_time_s"] for r in rs]
        n = sum(r["episodes"] for r in rs)
        k = round(sum(r["success_rate"] * r["episodes"] for r in rs))
        pooled = list(wilson_ci95(k, n))
        m, ci = mean_ci(succ)
        tm, tci = mean_ci(times)
        out.append(
            {
                "behavior": behavior,
                "method": method,
                "speed_mps": speed,
                "seeds": len(rs) if rs[0].get("seed") is not None else 0,
                "episodes": n,
                "success_rate": m,
                "success_ci95": clip01(ci) if ci else pooled,
                "ci_over": "seeds" if ci else "episodes",
                "pooled_ci95": pooled,
                "per_seed_success": succ,
                "per_seed_catch_time_s": times,
                "catch_time_s": tm,
                "catch_time_ci95": list(tci) if tci else None,
                "trained_on": rs[0].get("trained_on"),
            }
        )
    return out


def average_column(cells: list[dict]) -> list[dict]:
    """Table I's 'Average' column: per (behaviour, method), the mean over speeds of each
    seed's success, then mean and CI over seeds."""
    groups: dict[tuple, list[dict]] = {}
    for c in cells:
        groups.setdefault((c["behavior"], c["method"]), []).append(c)
    out = []
    for (behavior, method), cs in groups.items():
        per_seed = np.mean([c["per_seed_success"] for c in cs], axis=0).tolist()
        per_seed_time = np.mean([c["per_seed_catch_time_s"] for c in cs], axis=0).tolist()
        m, ci = mean_ci(per_seed)
        tm, tci = mean_ci(per_seed_time)
        n = sum(c["episodes"] for c in cs)
        k = round(sum(c["success_rate"] * c["episodes"] for c in cs))
        out.append(
            {
                "behavior": behavior,
                "method": method,
                "speed_mps": None,
                "episodes": n,
                "success_rate": m,
                "success_ci95": clip01(ci) if ci else list(wilson_ci95(k, n)),
                "per_seed_success": per_seed,
                "per_seed_catch_time_s": per_seed_time,
                "catch_time_s": tm,
                "catch_time_ci95": list(tci) if tci else None,
            }
        )
    return out


def _judged(metric: str, d: Difference) -> dict:
    """A check's numbers; ``judge_family`` adds its role and verdict."""
    return {
        "metric": metric,
        "difference": d.difference,
        "ci95": list(d.ci),
        "half_width": d.half_width,
        "df": d.df,
        "p_value": d.p_value,
    }


def gap(a: dict, b: dict) -> dict:
    """Success of ``a`` minus ``b`` with a 95 % CI: Welch over seeds (Satterthwaite's df)
    when both have 2+ seeds, else a normal interval on the pooled episode proportions."""
    sa, sb = a["per_seed_success"], b.get("per_seed_success", [b["success_rate"]])
    if len(sa) >= 2 and len(sb) >= 2:
        out = _judged("success_rate", welch(sa, sb))
        out["sd"] = [float(np.std(sa, ddof=1)), float(np.std(sb, ddof=1))]
        out["seeds"] = [len(sa), len(sb)]
        return out
    d = proportion_difference(a["success_rate"], a["episodes"], b["success_rate"], b["episodes"])
    return _judged("success_rate", d)


def time_gap(a: dict, b: dict) -> dict | None:
    """Seconds ``a`` catches sooner than ``b`` (``b``'s mean catch time minus ``a``'s), with
    a Welch CI over seeds; None unless both have 2+ seeds (per-episode times are not kept,
    so there is no single-seed interval)."""
    sa, sb = a.get("per_seed_catch_time_s", []), b.get("per_seed_catch_time_s", [])
    if len(sa) < 2 or len(sb) < 2:
        return None
    return _judged("catch_time_s", welch(sb, sa))


def _verdict(difference: float, significant: bool) -> str:
    if not significant:
        return "unresolved (CI spans 0)"
    return "holds" if difference > 0 else "reversed"


def _primary(check: dict, endpoint: Endpoint, alpha: float) -> dict:
    lo, hi = check["ci95"]
    out = {
        "role": "primary",
        "endpoint": endpoint.name,
        "margin": endpoint.margin,
        "smallest_resolvable_difference": check["half_width"],
        "equivalent_within_margin": -endpoint.margin < lo and hi < endpoint.margin,
        "verdict": _verdict(check["difference"], check["p_value"] < alpha),
    }
    out["resolution"] = (
        "resolved"
        if check["p_value"] < alpha
        else "equivalent within the margin"
        if out["equivalent_within_margin"]
        else "unresolved"
    )
    if "sd" in check:
        out["seeds_for_80pct_power_at_margin"] = seeds_for_power(endpoint.margin, *check["sd"])
    return out


def judge_family(
    checks: list[dict],
    endpoints: Sequence[Endpoint] = PRIMARY_ENDPOINTS,
    confidence: float = CONFIDENCE,
) -> list[dict]:
    """Label and judge ``checks`` as one family: those matching an endpoint are ``primary``
    (judged on their own p-value, with ``smallest_resolvable_difference``, the CI's
    half-width, and the seeds per method for 80 % power at the endpoint's margin); the rest
    are ``secondary``, judged on Holm-adjusted p-values over all of them (``p_holm``,
    ``family_size``). Reads only the raw numbers, so judging a union again is exact: call
    it once on every ordering and headroom check of a run."""
    alpha = 1 - confidence
    out, secondary = [], []
    for c in checks:
        c = {k: v for k, v in c.items() if k not in _JUDGEMENT_KEYS}
        endpoint = next((e for e in endpoints if e.matches(c)), None)
        if endpoint is None:
            c["role"] = "secondary"
            secondary.append(c)
        else:
            c.update(_primary(c, endpoint, alpha))
        out.append(c)
    for c, p in zip(secondary, holm([c["p_value"] for c in secondary]), strict=True):
        c["p_holm"] = float(p)
        c["family_size"] = len(secondary)
        c["verdict"] = _verdict(c["difference"], p < alpha)
        if p >= alpha and c["p_value"] < alpha:
            c["verdict"] = "unresolved (after Holm)"
    return out


_JUDGEMENT_KEYS = frozenset(
    {
        "role",
        "endpoint",
        "margin",
        "smallest_resolvable_difference",
        "equivalent_within_margin",
        "seeds_for_80pct_power_at_margin",
        "verdict",
        "resolution",
        "p_holm",
        "family_size",
    }
)


def ordering_checks(cells: list[dict], speeds, claims, endpoints=PRIMARY_ENDPOINTS) -> list[dict]:
    """``ordering_gaps`` judged by ``judge_family`` as a family of their own (a run judges
    all its checks as one family: ``dyncatch.reproduce.summary.judge``)."""
    return judge_family(ordering_gaps(cells, speeds, claims), endpoints)


def ordering_gaps(cells: list[dict], speeds, claims) -> list[dict]:
    """Each claim ``(winner, loser)`` (``reproduce.presentation.paper_claims()``)
    on success (``metric`` success_rate: difference in rate) and, with 2+ seeds, on catch
    time (``metric`` catch_time_s: seconds the first method saves), not yet judged."""
    by = {(c["behavior"], c["method"], c["speed_mps"]): c for c in cells}
    checks = []
    for behavior in dict.fromkeys(c["behavior"] for c in cells):
        for speed in speeds:
            for hi, lo in claims:
                a, b = by.get((behavior, hi, speed)), by.get((behavior, lo, speed))
                if a is None or b is None:
                    continue
                where = {
                    "kind": "ordering",
                    "behavior": behavior,
                    "speed_mps": speed,
                    "claim": f"{hi} > {lo}",
                }
                checks.append({**where, **gap(a, b)})
                faster = time_gap(a, b)
                if faster is not None:
                    checks.append({**where, **faster})
    return checks


def best_rival(cells: list[dict]) -> dict:
    """The best of several methods' cells: highest success, then shortest catch time."""
    return max(cells, key=lambda c: (c["success_rate"], -c["catch_time_s"]))


def headroom_checks(
    cells: list[dict], speeds, oracle: str, rivals, endpoints=PRIMARY_ENDPOINTS
) -> list[dict]:
    """``headroom_gaps`` judged by ``judge_family`` as a family of their own, as
    ``ordering_checks``."""
    return judge_family(headroom_gaps(cells, speeds, oracle, rivals), endpoints)


def headroom_gaps(cells: list[dict], speeds, oracle: str, rivals) -> list[dict]:
    """The room a benchmark leaves (issue 12): per behaviour and speed, ``oracle`` against
    the best of ``rivals`` there (``best_rival``), measured as ``ordering_gaps`` measures a
    claim (``claim`` is ``"oracle > best"``, ``best_non_oracle`` names the best), on success
    and, with 2+ seeds, on catch time, not yet judged. 'holds' means the oracle is
    measurably better: a method that reads what a robot can sense has room to improve."""
    by = {(c["behavior"], c["method"], c["speed_mps"]): c for c in cells}
    checks = []
    for behavior in dict.fromkeys(c["behavior"] for c in cells):
        for speed in speeds:
            top = by.get((behavior, oracle, speed))
            found = [by[k] for k in ((behavior, m, speed) for m in rivals) if k in by]
            if top is None or not found:
                continue
            best = best_rival(found)
            where = {
                "kind": "headroom",
                "behavior": behavior,
                "speed_mps": speed,
                "claim": f"{oracle} > {best['method']}",
                "best_non_oracle": best["method"],
            }
            checks.append({**where, **gap(top, best)})
            faster = time_gap(top, best)
            if faster is not None:
                checks.append({**where, **faster})
    return checks


def seed_means(
    cells: list[dict], method: str, speed_mps: float, behaviors: Sequence[str],
    key: str = "per_seed_success",
) -> list[float] | None:  # fmt: skip
    """Per seed, the mean over ``behaviors`` of ``method``'s ``key`` at ``speed_mps`` (a
    seed's runs on each behaviour are independent, so the behaviour-averaged seed is the
    unit of a study's interval); None unless every behaviour has the cell."""
    picked = {
        c["behavior"]: c[key]
        for c in cells
        if c["method"] == method and abs(c["speed_mps"] - speed_mps) < 1e-9
        and c["behavior"] in behaviors
    }  # fmt: skip
    if set(picked) != set(behaviors):
        return None
    return np.mean([picked[b] for b in behaviors], axis=0).tolist()
