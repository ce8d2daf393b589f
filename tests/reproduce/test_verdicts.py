"""The paper's Table I claims, one verdict each (reproduce/verdicts.py)."""

import pytest

from dyncatch.reproduce.verdicts import (
    level_against_paper,
    level_rows,
    ordering_rows,
    verdicts_markdown,
)


def _check(claim, behavior, speed, lo, hi, role="secondary", p_holm=0.01, metric="success_rate"):
    c = {"kind": "ordering", "claim": claim, "behavior": behavior, "speed_mps": speed,
         "metric": metric, "difference": (lo + hi) / 2, "ci95": [lo, hi], "role": role}  # fmt: skip
    if role == "secondary":
        c["p_holm"] = p_holm
    else:
        c["margin"] = 0.10
        c["resolution"] = "resolved" if lo > 0 or hi < 0 else "unresolved"
    return c


@pytest.mark.parametrize(
    ("ci", "paper", "verdict"),
    [
        ((0.53, 0.76), 0.0, "above the paper's value"),
        ((0.79, 0.906), 0.908, "below the paper's value"),
        ((0.85, 0.95), 0.908, "holds the paper's value"),
        ((0.0, 0.0), 0.0, "holds the paper's value"),
    ],
)
def test_a_level_holds_the_papers_value_or_lies_above_or_below_it(ci, paper, verdict):
    assert level_against_paper(ci, paper) == verdict


def test_orderings_read_the_papers_difference_and_the_family_correction():
    """Paper, reactive 1.8 m/s: sp_rl 0.908, rl 0.000, p_rl 0.009 (Table I)."""
    primary = _check("sp_rl > rl", "reactive", 1.8, 0.077, 0.325, role="primary")
    holm_lost = _check("sp_rl > p_rl", "reactive", 1.8, 0.01, 0.30, p_holm=0.08)
    holm_kept = _check("sp_rl > p_rl", "reactive", 1.6, 0.01, 0.30, p_holm=0.01)
    spans = _check("sp_rl > rl", "random_reactive", 1.8, -0.05, 0.95, p_holm=0.4)
    no_paper = _check("gt_rl > sp_rl", "reactive", 1.8, 0.05, 0.15)
    rows = ordering_rows([primary, holm_lost, holm_kept, spans, no_paper])
    assert [r["claim"] for r in rows] == [
        "sp_rl > rl",
        "sp_rl > p_rl",
        "sp_rl > p_rl",
        "sp_rl > rl",
    ]
    assert rows[0]["paper"] == pytest.approx(0.908)
    assert rows[0]["against_paper"] == "direction reproduced, smaller"
    assert rows[1]["paper"] == pytest.approx(0.899)
    assert rows[1]["against_paper"] == "unresolved after Holm, paper's value excluded"
    assert rows[2]["against_paper"] == "direction reproduced, smaller"
    assert rows[3]["against_paper"] == "unresolved"


def test_levels_come_from_cells_over_seeds_at_the_given_speeds():
    cells = [
        {"behavior": "reactive", "method": "rl", "speed_mps": 1.8, "seeds": 30,
         "success_rate": 0.648, "success_ci95": [0.536, 0.760], "ci_over": "seeds"},
        {"behavior": "reactive", "method": "rl", "speed_mps": 1.2, "seeds": 30,
         "success_rate": 0.99, "success_ci95": [0.98, 1.0], "ci_over": "seeds"},
        {"behavior": "reactive", "method": "pursuit", "speed_mps": 1.8, "seeds": 1,
         "success_rate": 0.0, "success_ci95": [0.0, 0.01], "ci_over": "episodes"},
        {"behavior": "reactive", "method": "gt_rl", "speed_mps": 1.8, "seeds": 30,
         "success_rate": 1.0, "success_ci95": [1.0, 1.0], "ci_over": "seeds"},
    ]  # fmt: skip
    [row] = level_rows(cells, [1.6, 1.8])
    assert (row["method"], row["paper"], row["against_paper"]) == (
        "rl",
        0.0,
        "above the paper's value",
    )
    table = verdicts_markdown([], [row])
    assert (
        "| rl catches | reactive | 1.8 m/s | success | 0.000 | 0.648 [0.536, 0.760] (30 seeds)"
        in table
    )


def test_fig9_levels_are_the_papers_method_where_its_text_gives_a_value():
    """The paper's text gives Room-0's success of its method with the blend (0.738 on
    reactive); other rows, scenes and single-seed cells have no verdict."""
    from dyncatch.reproduce.verdicts import fig9_level_rows

    def cell(scene, method, seeds=10, ci=(0.95, 0.99)):
        return {"scene": scene, "behavior": "reactive", "method": method, "seeds": seeds,
                "success_rate": sum(ci) / 2, "success_ci95": list(ci),
                "ci_over": "seeds" if seeds > 1 else "episodes"}  # fmt: skip

    cells = [
        cell("room_0", "sp_rl+blend"),
        cell("room_0", "sp_rl"),
        cell("room_8", "sp_rl+blend"),
        cell("room_0", "sp_rl+blend", seeds=1),
    ]
    [row] = fig9_level_rows(cells, 1.8)
    assert (row["method"], row["paper"], row["against_paper"]) == (
        "sp_rl+blend in room_0",
        0.738,
        "above the paper's value",
    )
    assert fig9_level_rows(cells[:1], None)[0]["speed"] == "drawn"
    assert "| sp_rl+blend in room_0 catches | reactive | 1.8 m/s | success | 0.738 |" in (
        verdicts_markdown([], [row])
    )


def test_table_ii_claim_is_the_sign_at_the_largest_budget_the_paper_gives():
    from dyncatch.reproduce.verdicts import predictor_rows

    def row(behavior, kind, budget, error, paper):
        return {"behavior": behavior, "kind": kind, "budget_steps": budget,
                "error_mps": error, "paper_error_mps": paper}  # fmt: skip

    table = [
        row("reactive", "vanilla", 500_000, 0.40, 1.201),
        row("reactive", "self_aware", 500_000, 0.10, 0.211),
        row("reactive", "vanilla", 2_000_000, 0.32, 1.197),
        row("reactive", "self_aware", 2_000_000, 0.08, 0.128),
        row("bounce", "vanilla", 2_000_000, 0.020, 0.022),
        row("bounce", "self_aware", 2_000_000, 0.025, 0.022),
        row("random_reactive", "vanilla", 2_000_000, 0.33, None),
        row("random_reactive", "self_aware", 2_000_000, 0.33, None),
    ]
    reactive, bounce = predictor_rows(table)
    assert (reactive["budget_steps"], reactive["ours"], reactive["paper"]) == pytest.approx(
        (2_000_000, 0.24, 1.069)
    )
    assert reactive["against_paper"] == "same sign as the paper's (one predictor: no CI)"
    # The paper's bounce errors are equal at 2 M (0 difference): no sign to agree with.
    assert bounce["against_paper"] == "the paper's errors are equal (one predictor: no CI)"
    flipped = [{**r, "error_mps": 1.0} if r["kind"] == "self_aware" else r for r in table]
    assert predictor_rows(flipped)[0]["against_paper"] == "the other sign (one predictor: no CI)"
    table_md = verdicts_markdown([], [], [reactive])
    assert (
        "| reactive | 2 M steps | error, vanilla - self_aware (m/s) | +1.069 | +0.240 |" in table_md
    )
