"""Seeds to intervals, the ordering checks and the headroom, on hand-worked numbers."""

from __future__ import annotations

import pytest

from dyncatch.reproduce.aggregate import (
    average_column,
    headroom_checks,
    ordering_checks,
    summarize_cells,
)
from dyncatch.reproduce.presentation import paper_claims
from dyncatch.rl.methods import METHODS


def _rows(method: str, success: list[float], times: list[float], speed: float = 1.8) -> list:
    return [
        {
            "behavior": "reactive",
            "method": method,
            "speed_mps": speed,
            "seed": s,
            "episodes": 100,
            "success_rate": p,
            "catch_time_s": t,
        }
        for s, (p, t) in enumerate(zip(success, times, strict=True))
    ]


class TestSuccessInterval:
    def test_t_interval_over_seeds_is_cut_to_the_unit_range(self):
        # mean 0.96, sample std 0.0529, t(2) = 4.303: 0.96 +- 0.1314 -> [0.829, 1.091] -> 1.0
        (cell,) = summarize_cells(_rows("sp_rl", [1.0, 0.9, 0.98], [5.0, 6.0, 5.5]))
        assert cell["success_rate"] == pytest.approx(0.96)
        assert cell["success_ci95"][0] == pytest.approx(0.96 - 4.303 * 0.052915 / 3**0.5, 1e-4)
        assert cell["success_ci95"][1] == 1.0
        assert cell["catch_time_s"] == pytest.approx(5.5)
        assert cell["per_seed_catch_time_s"] == [5.0, 6.0, 5.5]

    def test_average_column_averages_each_seed_over_speeds(self):
        rows = _rows("rl", [1.0, 0.8], [4.0, 6.0], 1.6) + _rows("rl", [0.6, 0.8], [8.0, 6.0])
        (avg,) = average_column(summarize_cells(rows))
        # seed 0: (1.0 + 0.6) / 2 = 0.8, seed 1: 0.8; times 6.0 and 6.0
        assert avg["per_seed_success"] == pytest.approx([0.8, 0.8])
        assert avg["success_ci95"] == pytest.approx([0.8, 0.8])
        assert avg["per_seed_catch_time_s"] == pytest.approx([6.0, 6.0])
        assert avg["catch_time_s"] == pytest.approx(6.0)


class TestOrderingChecks:
    def _checks(self, sp_time: list[float], rl_time: list[float]):
        cells = summarize_cells(
            _rows("sp_rl", [1.0, 1.0, 1.0], sp_time) + _rows("rl", [1.0, 1.0, 1.0], rl_time)
        )
        return {c["metric"]: c for c in ordering_checks(cells, [1.8], paper_claims())}

    def test_equal_success_is_unresolved_and_a_faster_catch_holds(self):
        checks = self._checks([5.0, 5.2, 5.4], [6.0, 6.2, 6.4])
        assert checks["success_rate"]["difference"] == 0.0
        assert checks["success_rate"]["verdict"].startswith("unresolved")
        # 1.0 s saved; Welch se = sqrt(0.04/3 + 0.04/3) = 0.1633, x 4.303 = 0.7027
        t = checks["catch_time_s"]
        assert t["difference"] == pytest.approx(1.0)
        assert t["ci95"] == pytest.approx([1.0 - 0.7027, 1.0 + 0.7027], abs=1e-3)
        assert t["verdict"] == "holds"

    def test_a_slower_catch_is_reversed(self):
        checks = self._checks([7.0, 7.2, 7.4], [5.0, 5.2, 5.4])
        assert checks["catch_time_s"]["difference"] == pytest.approx(-2.0)
        assert checks["catch_time_s"]["verdict"] == "reversed"

    def test_one_seed_gives_no_catch_time_check(self):
        cells = summarize_cells(_rows("sp_rl", [0.9], [5.0]) + _rows("rl", [0.5], [9.0]))
        checks = ordering_checks(cells, [1.8], paper_claims())
        assert [c["metric"] for c in checks] == ["success_rate"]
        # pooled episodes: 0.4 +- 1.96 * sqrt(0.09/100 + 0.25/100) = 0.4 +- 0.1143
        assert checks[0]["ci95"] == pytest.approx([0.4 - 0.11429, 0.4 + 0.11429], abs=1e-4)
        assert checks[0]["verdict"] == "holds"


class TestHeadroom:
    def test_the_oracle_meets_the_best_rival_on_success_then_catch_time(self):
        rows = (
            _rows("gt_rl", [1.0, 0.99, 0.98], [7.0, 7.5, 8.0])
            + _rows("rl", [0.9, 0.92, 0.94], [11.0, 11.5, 12.0])
            # p_rl and sp_rl tie on success: the faster one (sp_rl) is the best rival.
            + _rows("p_rl", [0.96, 0.96, 0.96], [10.5, 11.0, 11.5])
            + _rows("sp_rl", [0.96, 0.96, 0.96], [10.0, 10.5, 11.0])
        )
        cells = summarize_cells(rows)
        rivals = [n for n in ("rl", "p_rl", "sp_rl", "gt_rl") if not METHODS[n].oracle]
        assert rivals == ["rl", "p_rl", "sp_rl"]
        checks = {c["metric"]: c for c in headroom_checks(cells, [1.8], "gt_rl", rivals)}
        assert {c["best_non_oracle"] for c in checks.values()} == {"sp_rl"}
        assert checks["success_rate"]["claim"] == "gt_rl > sp_rl"
        # 0.99 - 0.96 = 0.03; Welch se = sqrt(0.0001 / 3 + 0 / 3) = 0.005774, x 4.303 = 0.02484
        s = checks["success_rate"]
        assert s["difference"] == pytest.approx(0.03)
        assert s["ci95"] == pytest.approx([0.03 - 0.02484, 0.03 + 0.02484], abs=1e-4)
        assert s["verdict"] == "holds"
        # 10.5 - 7.5 = 3.0 s; se = sqrt(0.25/3 + 0.25/3) = 0.4082, x 4.303 = 1.7566
        t = checks["catch_time_s"]
        assert t["difference"] == pytest.approx(3.0)
        assert t["ci95"] == pytest.approx([3.0 - 1.7566, 3.0 + 1.7566], abs=1e-3)

    def test_no_oracle_cell_gives_no_check(self):
        cells = summarize_cells(_rows("rl", [0.9, 0.8], [9.0, 9.5]))
        assert headroom_checks(cells, [1.8], "gt_rl", ["rl"]) == []
