"""Seeds to means and 95 % confidence intervals, the ordering checks of the paper, and the
benchmark's headroom (the oracle against the best non-oracle method)."""

from __future__ import annotations

import math

import numpy as np

from dyncatch.evaluation.stats import wilson_ci95

T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}
"""Two-sided 95 % Student-t quantiles by degrees of freedom (1.96 beyond)."""


def t95(df: int) -> float:
    return T95.get(df, 1.96)


def mean_ci(values: list[float]) -> tuple[float, tuple[float, float] | None]:
    """Mean and t-interval over seeds (None with a single seed)."""
    x = np.asarray(values, float)
    m = float(x.mean())
    if x.size < 2:
        return m, None
    half = t95(x.size - 1) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return m, (m - half, m + half)


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


def _welch_half(sa: list[float], sb: list[float]) -> float:
    se = math.sqrt(np.var(sa, ddof=1) / len(sa) + np.var(sb, ddof=1) / len(sb))
    return t95(min(len(sa), len(sb)) - 1) * se


def _judged(metric: str, difference: float, half: float) -> dict:
    lo, hi = difference - half, difference + half
    verdict = "holds" if lo > 0 else ("reversed" if hi < 0 else "unresolved (CI spans 0)")
    return {"metric": metric, "difference": difference, "ci95": [lo, hi], "verdict": verdict}


def gap(a: dict, b: dict) -> dict:
    """Success of ``a`` minus ``b`` with a 95 % CI: Welch over seeds when both have 2+
    seeds, else a normal interval on the pooled episode proportions."""
    sa, sb = a["per_seed_success"], b.get("per_seed_success", [b["success_rate"]])
    d = a["success_rate"] - b["success_rate"]
    if len(sa) >= 2 and len(sb) >= 2:
        half = _welch_half(sa, sb)
    else:
        na, nb = a["episodes"], b["episodes"]
        pa, pb = a["success_rate"], b["success_rate"]
        half = 1.96 * math.sqrt(max(pa * (1 - pa), 1e-12) / na + max(pb * (1 - pb), 1e-12) / nb)
    return _judged("success_rate", d, half)


def time_gap(a: dict, b: dict) -> dict | None:
    """Seconds ``a`` catches sooner than ``b`` (``b``'s mean catch time minus ``a``'s), with
    a Welch CI over seeds; None unless both have 2+ seeds (per-episode times are not kept,
    so there is no single-seed interval)."""
    sa, sb = a.get("per_seed_catch_time_s", []), b.get("per_seed_catch_time_s", [])
    if len(sa) < 2 or len(sb) < 2:
        return None
    return _judged("catch_time_s", b["catch_time_s"] - a["catch_time_s"], _welch_half(sa, sb))


def ordering_checks(cells: list[dict], speeds, claims) -> list[dict]:
    """Each claim ``(winner, loser)`` (``dyncatch.rl.methods.paper_claims()``) on success
    (``metric`` success_rate: difference in rate) and, with 2+ seeds, on catch time
    (``metric`` catch_time_s: seconds the first method saves)."""
    by = {(c["behavior"], c["method"], c["speed_mps"]): c for c in cells}
    checks = []
    for behavior in dict.fromkeys(c["behavior"] for c in cells):
        for speed in speeds:
            for hi, lo in claims:
                a, b = by.get((behavior, hi, speed)), by.get((behavior, lo, speed))
                if a is None or b is None:
                    continue
                where = {"behavior": behavior, "speed_mps": speed, "claim": f"{hi} > {lo}"}
                checks.append({**where, **gap(a, b)})
                faster = time_gap(a, b)
                if faster is not None:
                    checks.append({**where, **faster})
    return checks


def best_rival(cells: list[dict]) -> dict:
    """The best of several methods' cells: highest success, then shortest catch time."""
    return max(cells, key=lambda c: (c["success_rate"], -c["catch_time_s"]))


def headroom_checks(cells: list[dict], speeds, oracle: str, rivals) -> list[dict]:
    """The room a benchmark leaves (issue 12): per behaviour and speed, ``oracle`` against
    the best of ``rivals`` there (``best_rival``), judged as ``ordering_checks`` judges a
    claim (``claim`` is ``"oracle > best"``, ``best_non_oracle`` names the best), on success
    and, with 2+ seeds, on catch time. 'holds' means the oracle is measurably better: a
    method that reads what a robot can sense has room to improve."""
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
