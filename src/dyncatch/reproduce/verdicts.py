"""The paper's Table I claims, one row each, with our value and the verdict on each.

Two kinds of claim, both read from a run's ``results.json`` content:

- **orderings** (``sp_rl > rl`` and the others of ``presentation.paper_claims``) at each
  speed the run judged, on success and on catch time: the paper's difference against ours
  with its 95 % CI, judged by ``endpoints.against_paper`` where the run resolves it (a
  primary endpoint on its own p-value, a secondary check on its Holm-adjusted one); a
  secondary whose CI excludes 0 but whose Holm-adjusted p-value does not resolve it reads
  ``unresolved after Holm``;
- **levels**: each learned method's success at the high speeds, and Fig. 9's where the
  paper's text gives it (its method with the blend, Room-0), the paper's value against our
  CI over seeds (``level_against_paper``): ``holds the paper's value``, or ours above or
  below it;
- **Table II's**: the self-aware predictor's error below the vanilla one's, per behaviour
  (``predictor_rows``; one predictor a cell, so the sign only).
"""

from __future__ import annotations

from dyncatch.evaluation.intervals import CONFIDENCE
from dyncatch.reproduce.endpoints import against_paper
from dyncatch.reproduce.paper import (
    PAPER_FIG9_METHOD,
    PAPER_FIG9_SUCCESS,
    paper_cell,
    paper_difference,
)

ALPHA = 1 - CONFIDENCE
"""Two-sided level of every test, that of aggregate's intervals."""


def level_against_paper(ci95: tuple[float, float], paper: float) -> str:
    """Whether our interval holds the paper's value, or lies above or below it."""
    lo, hi = ci95
    if paper < lo:
        return "above the paper's value"
    if paper > hi:
        return "below the paper's value"
    return "holds the paper's value"


def _ordering_verdict(check: dict, paper: float, margin: float) -> str:
    if check.get("role") == "primary":
        return against_paper(tuple(check["ci95"]), paper, check["resolution"], margin)
    holm = check.get("p_holm")
    resolved = holm is not None and holm < ALPHA
    verdict = against_paper(
        tuple(check["ci95"]), paper, "resolved" if resolved else "unresolved", margin
    )
    lo, hi = check["ci95"]
    if not resolved and (lo > 0 or hi < 0):
        verdict = verdict.replace("unresolved", "unresolved after Holm", 1)
    return verdict


def ordering_rows(checks: list[dict], margin: float = 0.10) -> list[dict]:
    """Every judged ordering check at a speed (or the average) where the paper gives both
    methods a number, with the paper's difference and the verdict on it. ``margin`` is the
    equivalence margin of ``against_paper`` (a primary endpoint's own, where it has one)."""
    rows = []
    for c in checks:
        winner, _, loser = c["claim"].partition(" > ")
        metric = c.get("metric", "success_rate")
        paper = paper_difference(c["behavior"], winner, loser, c["speed_mps"], metric)
        if paper is None:
            continue
        verdict = _ordering_verdict(c, paper, c.get("margin", margin))
        rows.append({**c, "metric": metric, "paper": paper, "against_paper": verdict})
    return rows


def level_rows(cells: list[dict], speeds_mps) -> list[dict]:
    """Each learned method's success at ``speeds_mps`` (cells with 2+ seeds) where the
    paper gives a number: ours with its CI over seeds, the paper's, the verdict."""
    rows = []
    for c in cells:
        if c.get("ci_over") != "seeds" or not any(
            abs(c["speed_mps"] - s) < 1e-9 for s in speeds_mps
        ):
            continue
        paper = paper_cell(c["behavior"], c["method"], c["speed_mps"])
        if paper is None:
            continue
        ci = tuple(c["success_ci95"])
        rows.append(
            {
                "behavior": c["behavior"],
                "method": c["method"],
                "speed_mps": c["speed_mps"],
                "seeds": c["seeds"],
                "ours": c["success_rate"],
                "ci95": list(ci),
                "paper": paper[0],
                "against_paper": level_against_paper(ci, paper[0]),
            }
        )
    return rows


def fig9_level_rows(cells: list[dict], speed_mps: float | None) -> list[dict]:
    """Fig. 9's cells of the paper's method (with the blend) where its text gives a success
    (over 2+ seeds): ours with its CI, the paper's, the verdict. ``speed_mps`` is the plan's
    Fig. 9 speed (None: drawn per episode)."""
    rows = []
    for c in cells:
        paper = PAPER_FIG9_SUCCESS.get((c["scene"], c["behavior"]))
        if c["method"] != PAPER_FIG9_METHOD or paper is None or c.get("ci_over") != "seeds":
            continue
        ci = tuple(c["success_ci95"])
        rows.append(
            {
                "behavior": c["behavior"],
                "method": f"{c['method']} in {c['scene']}",
                "speed_mps": speed_mps,
                "speed": "drawn" if speed_mps is None else f"{speed_mps:g} m/s",
                "seeds": c["seeds"],
                "ours": c["success_rate"],
                "ci95": list(ci),
                "paper": paper,
                "against_paper": level_against_paper(ci, paper),
            }
        )
    return rows


def predictor_rows(table_ii: list[dict]) -> list[dict]:
    """Table II's claim, the self-aware predictor's error below the vanilla one's, per
    behaviour at the largest budget where the paper gives both: the paper's difference
    (vanilla minus self-aware, m/s) against ours. One predictor per cell, so no CI: the
    verdict says only whether the sign is the paper's."""
    cells = {(r["behavior"], r["kind"], r["budget_steps"]): r for r in table_ii}
    rows = []
    for behavior in dict.fromkeys(r["behavior"] for r in table_ii):
        budgets = sorted(
            b
            for (beh, kind, b), r in cells.items()
            if beh == behavior and kind == "vanilla" and r.get("paper_error_mps") is not None
            and (beh, "self_aware", b) in cells
            and cells[(beh, "self_aware", b)].get("paper_error_mps") is not None
        )  # fmt: skip
        if not budgets:
            continue
        vanilla, aware = (
            cells[(behavior, "vanilla", budgets[-1])],
            cells[(behavior, "self_aware", budgets[-1])],
        )
        ours = vanilla["error_mps"] - aware["error_mps"]
        paper = vanilla["paper_error_mps"] - aware["paper_error_mps"]
        if paper == 0:
            verdict = "the paper's errors are equal"
        else:
            verdict = "same sign as the paper's" if ours * paper > 0 else "the other sign"
        rows.append(
            {
                "behavior": behavior,
                "budget_steps": budgets[-1],
                "ours": ours,
                "paper": paper,
                "against_paper": verdict + " (one predictor: no CI)",
            }
        )
    return rows


def _speed(speed_mps) -> str:
    return "average" if speed_mps is None else f"{speed_mps:g} m/s"


def verdicts_markdown(
    orderings: list[dict], levels: list[dict], predictors: list[dict] = ()
) -> str:
    """The kinds of claim as one table: claim, the paper's value, ours [95 % CI], role,
    verdict on the paper's claim."""
    lines = [
        "| claim | behaviour | speed | measure | paper | ours [95 % CI] | role "
        "| against the paper |",
        "|---|---|---|---|---:|---|---|---|",
    ]
    for r in orderings:
        lo, hi = r["ci95"]
        measure = "success" if r["metric"] == "success_rate" else "catch time (s saved)"
        role = r.get("role", "")
        if role == "secondary" and "p_holm" in r:
            role += f", p (Holm) {r['p_holm']:.2g}"
        lines.append(
            f"| {r['claim']} | {r['behavior']} | {_speed(r['speed_mps'])} | {measure} | "
            f"{r['paper']:+.3f} | {r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}] | {role} | "
            f"{r['against_paper']} |"
        )
    for r in levels:
        lo, hi = r["ci95"]
        lines.append(
            f"| {r['method']} catches | {r['behavior']} | "
            f"{r.get('speed') or _speed(r['speed_mps'])} | success | "
            f"{r['paper']:.3f} | {r['ours']:.3f} [{lo:.3f}, {hi:.3f}] ({r['seeds']} seeds) | "
            f"level | {r['against_paper']} |"
        )
    for r in predictors:
        lines.append(
            f"| self_aware predictor's error below vanilla's | {r['behavior']} | "
            f"{r['budget_steps'] / 1e6:g} M steps | error, vanilla - self_aware (m/s) | "
            f"{r['paper']:+.3f} | {r['ours']:+.3f} | Table II | {r['against_paper']} |"
        )
    return "\n".join(lines)
