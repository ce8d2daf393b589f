"""Two seed sets of one plan: the primary endpoints side by side, and what is refused."""

import copy

import pytest

from dyncatch.reproduce.replication import compare, replication_markdown


def _results(first_seed: int, difference: float, lo: float, hi: float, resolution: str) -> dict:
    verdict = "holds" if difference > 0 else "reversed"
    row = {"endpoint": "sp_rl_vs_rl_reactive", "claim": "sp_rl > rl", "behavior": "reactive",
           "speed_mps": 1.8, "difference": difference, "ci95": [lo, hi],
           "resolution": resolution, "verdict": verdict}  # fmt: skip
    plan = {"seeds": 10, "first_seed": first_seed, "episodes": 300}
    return {"plan": plan, "primary_endpoints": {"measured": [row]}}


def test_two_sets_agree_only_on_the_same_outcome_and_direction():
    a = _results(0, 0.12, 0.03, 0.21, "resolved")
    rows = compare(a, _results(10, 0.09, 0.01, 0.17, "resolved"))
    assert [r["agree"] for r in rows] == [True] and rows[0]["sets"] == ["0-9", "10-19"]
    assert compare(a, _results(10, 0.05, -0.03, 0.13, "unresolved"))[0]["agree"] is False
    assert compare(a, _results(10, -0.12, -0.2, -0.03, "resolved"))[0]["agree"] is False
    table = replication_markdown(rows)
    assert "| yes |" in table and "+0.120 [+0.030, +0.210]" in table


def test_overlapping_seeds_or_another_plan_is_not_a_replication():
    a = _results(0, 0.12, 0.03, 0.21, "resolved")
    with pytest.raises(ValueError, match="share seeds .*--first-seed"):
        compare(a, _results(5, 0.1, 0.0, 0.2, "resolved"))
    other = _results(10, 0.1, 0.0, 0.2, "resolved")
    other["plan"]["episodes"] = 1000
    with pytest.raises(ValueError, match="different plans \\(episodes\\)"):
        compare(a, other)
    # A plan recorded before first_seed existed started at seed 0.
    legacy = copy.deepcopy(a)
    del legacy["plan"]["first_seed"]
    assert compare(legacy, _results(10, 0.1, 0.02, 0.2, "resolved"))[0]["sets"][0] == "0-9"
