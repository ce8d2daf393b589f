"""The cross-evaluation's summary on hand-made cells: the seeds' means with t-intervals and
the difference of two methods with Welch's interval, worked out by hand. (Its cells on a
trained study: tests/rl/test_selfplay.py, TestCrossEvaluation.)"""

import pytest
import scipy.stats

from dyncatch.evaluation.intervals import t_quantile
from dyncatch.rl.cross_eval import (
    cross_rows,
    cross_table,
    difference_rows,
    difference_table,
    method_difference,
)


def cell(method, k, opponent, success, catch_time_s):
    result = {"speeds_mps": [1.4, 1.8], "success": success, "catch_time_s": catch_time_s}
    return {"method": method, "pursuer_round": k, "opponent": opponent, "result": result}


# Two seeds x two speeds. sp_rl: success per seed over the speeds 0.5, 0.7, catch time 10,
# 12 s; rl: 0.2, 0.3 and 15, 15 s. A third cell has rl alone (no difference row).
CELLS = [
    cell("sp_rl", 0, "round0", [[0.4, 0.6], [0.6, 0.8]], [[10.0, 10.0], [12.0, 12.0]]),
    cell("rl", 0, "round0", [[0.1, 0.3], [0.3, 0.3]], [[15.0, 15.0], [14.0, 16.0]]),
    cell("rl", 0, "reactive", [[1.0, 0.0], [1.0, 0.0]], [[5.0, 20.0], [5.0, 20.0]]),
]


def test_rows_are_the_seeds_means_with_t_intervals():
    rows = cross_rows(CELLS)
    assert [(r["method"], r["opponent"], r["seeds"]) for r in rows] == [
        ("sp_rl", "round0", 2),
        ("rl", "round0", 2),
        ("rl", "reactive", 2),
    ]
    s = rows[0]["success"]
    # Over the speeds 0.5, 0.7: mean 0.6, sd 0.1414, se 0.1, t(0.975, 1 df) 12.706. Per
    # speed 0.4, 0.6 and 0.6, 0.8: means 0.5, 0.7 with the same half-width.
    half = t_quantile(1) * 0.1
    assert s["mean"] == pytest.approx(0.6) and s["ci"] == pytest.approx([0.6 - half, 0.6 + half])
    assert s["per_speed"] == pytest.approx([0.5, 0.7])
    assert s["per_speed_ci"][1] == pytest.approx([0.7 - half, 0.7 + half])
    t = rows[2]["catch_time_s"]  # 5 and 20 s for both seeds: no spread
    assert t["mean"] == 12.5 and t["per_speed"] == [5.0, 20.0] and t["ci"] == [12.5, 12.5]
    one_seed = cross_rows([cell("rl", 1, "round1", [[0.5, 0.5]], [[3.0, 4.0]])])[0]
    assert one_seed["success"]["ci"] is None and one_seed["catch_time_s"]["mean"] == 3.5


def test_the_difference_row_is_welchs():
    (row,) = difference_rows(CELLS, ("sp_rl", "rl"))
    assert (row["compare"], row["pursuer_round"], row["opponent"]) == (["sp_rl", "rl"], 0, "round0")
    # Success: 0.6 - 0.25 = 0.35; variances 0.02 and 0.005 over 2 seeds each: se
    # sqrt(0.01 + 0.0025) = 0.1118, Welch df 0.0125^2 / (0.01^2 + 0.0025^2) = 1.4706,
    # t(0.975, 1.4706) = 6.188: half-width 0.6919.
    s = row["success"]
    se, df = 0.0125**0.5, 0.0125**2 / (0.01**2 + 0.0025**2)
    assert df == pytest.approx(1.4706, abs=1e-4)
    assert t_quantile(df) * se == pytest.approx(0.6919, abs=1e-4)
    assert s["difference"] == pytest.approx(0.35)
    assert s["ci"] == pytest.approx([0.35 - 0.69185, 0.35 + 0.69185], abs=1e-4)
    assert s["p_value"] == pytest.approx(2 * scipy.stats.t.sf(0.35 / se, df))
    # Catch time: 11 - 15 = -4 s; variances 2 and 0: se 1, df 1: half-width 12.706.
    t = row["catch_time_s"]
    assert t["difference"] == pytest.approx(-4.0)
    assert t["ci"] == pytest.approx([-4.0 - 12.7062, -4.0 + 12.7062], abs=1e-4)
    assert difference_rows(CELLS, ("p_rl", "rl")) == []


def test_one_seed_has_no_interval():
    assert method_difference([0.5], [0.25, 0.75]) == {
        "difference": 0.0,
        "ci": None,
        "p_value": None,
    }


def test_tables_have_a_line_per_row():
    rows = cross_rows(CELLS)
    lines = cross_table(rows)
    assert lines[0].startswith("| method | pursuer round | opponent | seeds | success 1.4 m/s")
    assert len(lines) == 2 + 3
    assert lines[4].startswith("| rl | 0 | reactive | 2 | 1.000 [1.000, 1.000] | 0.000")
    diff = difference_table(difference_rows(CELLS, ("sp_rl", "rl")))
    assert diff[0].startswith("| pursuer round | opponent | success sp_rl - rl |")
    assert diff[2].startswith("| 0 | round0 | 0.350 [-0.342, 1.042] | 0.129 |")
    assert cross_table([]) == [] and difference_table([]) == []
