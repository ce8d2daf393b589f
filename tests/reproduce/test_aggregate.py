"""Seeds to intervals, the ordering checks and the headroom, on hand-worked numbers."""

from __future__ import annotations

import pytest

from dyncatch.reproduce.aggregate import (
    average_column,
    headroom_checks,
    judge_family,
    ordering_checks,
    summarize_cells,
)
from dyncatch.reproduce.presentation import paper_claims
from dyncatch.reproduce.robust import improvement_probabilities, robust_summary
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
        # 1.0 s saved; Welch se = sqrt(0.04/3 + 0.04/3) = 0.1633; equal variances and n:
        # Satterthwaite df = 2n - 2 = 4, t(4) = 2.7764 -> half 0.4534
        t = checks["catch_time_s"]
        assert t["difference"] == pytest.approx(1.0)
        assert t["df"] == pytest.approx(4.0)
        assert t["ci95"] == pytest.approx([1.0 - 0.4534, 1.0 + 0.4534], abs=1e-3)
        assert t["verdict"] == "holds"
        assert t["role"] == "secondary"

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
        # 0.99 - 0.96 = 0.03; Welch se = sqrt(0.0001 / 3 + 0 / 3) = 0.005774; one side without
        # spread: df = 3 - 1 = 2, t(2) = 4.303 -> 0.02484
        s = checks["success_rate"]
        assert s["difference"] == pytest.approx(0.03)
        assert s["ci95"] == pytest.approx([0.03 - 0.02484, 0.03 + 0.02484], abs=1e-4)
        assert s["verdict"] == "holds"
        # 10.5 - 7.5 = 3.0 s; se = sqrt(0.25/3 + 0.25/3) = 0.4082, df 4: x 2.7764 = 1.1334
        t = checks["catch_time_s"]
        assert t["difference"] == pytest.approx(3.0)
        assert t["ci95"] == pytest.approx([3.0 - 1.1334, 3.0 + 1.1334], abs=1e-3)

    def test_no_oracle_cell_gives_no_check(self):
        cells = summarize_cells(_rows("rl", [0.9, 0.8], [9.0, 9.5]))
        assert headroom_checks(cells, [1.8], "gt_rl", ["rl"]) == []


class TestFamily:
    """Primary endpoints are judged alone; the rest are one Holm family."""

    def _cells(self):
        rows = []
        for behavior in ("reactive", "random_reactive"):
            for method, succ in (("sp_rl", [0.9, 0.92, 0.94]), ("rl", [0.7, 0.8, 0.9])):
                rows += [{**r, "behavior": behavior} for r in _rows(method, succ, [5.0, 5.5, 6.0])]
        return summarize_cells(rows)

    def test_the_declared_endpoints_are_primary(self):
        checks = ordering_checks(self._cells(), [1.8], [("sp_rl", "rl")])
        success = [c for c in checks if c["metric"] == "success_rate"]
        assert {c["role"] for c in success} == {"primary"}
        assert {c["endpoint"] for c in success} == {
            "sp_rl_vs_rl_reactive",
            "sp_rl_vs_rl_random_reactive",
        }
        c = success[0]
        # 0.92 - 0.80: sd 0.02 and 0.1, n 3: se = sqrt(0.0004/3 + 0.01/3) = 0.058878;
        # df = 0.0104^2/9 / ((0.0004/3)^2/2 + (0.01/3)^2/2) = 2.1597; t(2.16) ~ 4.08
        assert c["difference"] == pytest.approx(0.12)
        assert c["smallest_resolvable_difference"] == c["half_width"]
        assert c["df"] == pytest.approx(2.1597, abs=1e-3)
        assert c["verdict"].startswith("unresolved")
        assert c["equivalent_within_margin"] is False
        assert c["seeds_for_80pct_power_at_margin"] >= 3
        times = [c for c in checks if c["metric"] == "catch_time_s"]
        assert {c["role"] for c in times} == {"secondary"}
        assert {c["family_size"] for c in times} == {2}

    def test_holm_turns_a_marginal_secondary_unresolved(self):
        checks = [
            {"kind": "ordering", "behavior": "circle", "speed_mps": 1.8, "claim": "a > b",
             "metric": "success_rate", "difference": d, "ci95": [d - 0.01, d + 0.01],
             "half_width": 0.01, "df": 9.0, "p_value": p}
            for d, p in ((0.1, 0.04), (0.2, 0.001))
        ]  # fmt: skip
        judged = judge_family(checks)
        # Holm: 0.001 x 2 = 0.002, 0.04 x 1 -> max(0.04, 0.002) = 0.04 < 0.05: both hold
        assert [c["verdict"] for c in judged] == ["holds", "holds"]
        judged = judge_family(checks + [{**checks[0], "p_value": 0.5}])
        # three: 0.001 x 3 = 0.003, 0.04 x 2 = 0.08, 0.5 x 1 -> 0.08, 0.003, 0.5
        assert [c["p_holm"] for c in judged] == pytest.approx([0.08, 0.003, 0.5])
        assert judged[0]["verdict"] == "unresolved (after Holm)"
        # judging a judged list again gives the same verdicts (only raw numbers are read)
        assert judge_family(judged) == judged

    def test_an_interval_inside_the_margin_is_equivalence(self):
        (c,) = judge_family(
            [
                {
                    "kind": "headroom",
                    "behavior": "reactive",
                    "speed_mps": 1.8,
                    "claim": "gt_rl > sp_rl",
                    "metric": "success_rate",
                    "difference": 0.01,
                    "ci95": [-0.05, 0.07],
                    "half_width": 0.06,
                    "df": 18.0,
                    "p_value": 0.7,
                }
            ]  # fmt: skip
        )
        assert c["endpoint"] == "oracle_headroom_reactive"
        assert c["verdict"].startswith("unresolved")
        assert c["equivalent_within_margin"] is True


class TestRobust:
    def test_iqm_and_improvement_over_behaviours(self):
        rows = []
        for behavior in ("reactive", "random_reactive"):
            for method, succ in (("sp_rl", [0.9, 0.92, 0.94, 0.96]), ("rl", [0.1, 0.2, 0.3, 0.4])):
                rows += [{**r, "behavior": behavior} for r in _rows(method, succ, [5.0] * 4)]
        cells = summarize_cells(rows)
        summary = {s["method"]: s for s in robust_summary(cells, [1.8], ["sp_rl", "rl"], 500)}
        # 8 scores 0.9 0.9 0.92 0.92 0.94 0.94 0.96 0.96: the middle four average 0.93
        assert summary["sp_rl"]["iqm"] == pytest.approx(0.93)
        assert summary["sp_rl"]["seeds"] == 4 and summary["sp_rl"]["behaviors"] == 2
        lo, hi = summary["sp_rl"]["mean_ci95"]
        assert 0.9 <= lo <= 0.93 <= hi <= 0.96
        (p,) = improvement_probabilities(cells, [1.8], [("sp_rl", "rl")], 200)
        # every sp_rl seed beats every rl seed on both behaviours
        assert p["p_improvement"] == 1.0 and p["ci95"] == [1.0, 1.0]
