"""A run's checks judged as one family, the plan's primary endpoints (declared, recorded,
validated, reported), and the rliable summaries in results.json."""

from __future__ import annotations

import json

import pytest

from dyncatch.reproduce.aggregate import average_column, summarize_cells
from dyncatch.reproduce.endpoints import (
    PRIMARY_ENDPOINTS,
    Endpoint,
    against_paper,
    parse_endpoint,
)
from dyncatch.reproduce.layout import check_plan
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.report import primary_markdown
from dyncatch.reproduce.summary import judge, primary_rows
from dyncatch.reproduce.validate import validate_plan

METHODS = ("rl", "sp_rl", "gt_rl")
SUCCESS = {"rl": [0.5, 0.7, 0.9], "sp_rl": [0.9, 0.92, 0.94], "gt_rl": [0.97, 0.98, 0.99]}


def _cells(speeds=(1.6, 1.8), behaviors=("reactive", "random_reactive")):
    rows = [
        {
            "behavior": b,
            "method": m,
            "speed_mps": v,
            "seed": s,
            "episodes": 100,
            "success_rate": p,
            "catch_time_s": 5.0 + s + (m == "rl"),
        }
        for b in behaviors
        for v in speeds
        for m in METHODS
        for s, p in enumerate(SUCCESS[m])
    ]
    cells = summarize_cells(rows)
    return cells, average_column(cells)


class TestOneFamily:
    def test_every_check_of_a_run_is_judged_once_as_one_family(self):
        plan = Plan(methods=METHODS, speeds_mps=(1.6, 1.8))
        ordering, headroom = judge(plan, *_cells())
        every = ordering + headroom
        assert {c["kind"] for c in ordering} == {"ordering"}
        assert {c["kind"] for c in headroom} == {"headroom"}
        secondary = [c for c in every if c["role"] == "secondary"]
        primary = [c for c in every if c["role"] == "primary"]
        # 2 behaviours x (2 speeds + the average) x 2 measures of sp_rl > rl, and
        # 2 behaviours x 2 speeds x 2 measures of the headroom: 20 checks, 4 of them primary
        assert len(every) == 20 and len(primary) == 4
        assert {c["endpoint"] for c in primary} == {e.name for e in PRIMARY_ENDPOINTS}
        # one Holm family over ordering, averages and headroom alike (16, not 8 + 4 + 4)
        assert {c["family_size"] for c in secondary} == {len(secondary)} == {16}
        assert not any("p_holm" in c for c in primary)

    def test_the_plan_chooses_its_endpoints(self):
        one = (parse_endpoint("sp_rl-rl:reactive:1.6"),)
        ordering, headroom = judge(
            Plan(methods=METHODS, speeds_mps=(1.6, 1.8), primary_endpoints=one), *_cells()
        )
        (p,) = [c for c in ordering + headroom if c["role"] == "primary"]
        assert p["endpoint"] == "sp_rl_vs_rl_reactive_1.6mps" and p["speed_mps"] == 1.6
        assert {c["family_size"] for c in ordering + headroom if "family_size" in c} == {19}


class TestPrimaryTable:
    def test_the_table_gives_the_paper_ours_and_what_the_run_resolves(self):
        plan = Plan(methods=METHODS, speeds_mps=(1.8,), behaviors=("reactive",))
        ordering, headroom = judge(plan, *_cells((1.8,), ("reactive",)))
        primary = primary_rows(plan, ordering + headroom)
        assert [c["endpoint"] for c in primary["measured"]] == [
            "sp_rl_vs_rl_reactive",
            "oracle_headroom_reactive",
        ]
        assert primary["not_measured"] == [
            "sp_rl_vs_rl_random_reactive",
            "oracle_headroom_random_reactive",
        ]
        order, room = primary["measured"]
        # Table I at 1.8 m/s on reactive: sp_rl 0.908, rl 0.0; no gt_rl row
        assert order["paper_difference"] == pytest.approx(0.908)
        assert room["paper_difference"] is None
        # 0.92 - 0.70 = 0.22, sd 0.02 and 0.2 over 3 seeds: the CI spans 0
        assert order["difference"] == pytest.approx(0.22)
        assert order["resolution"] == "unresolved"
        # the CI spans 0 and excludes the paper's +0.908
        assert order["against_paper"] == "unresolved, paper's value excluded"
        assert room["against_paper"] is None
        text = primary_markdown(primary)
        assert (
            "| sp_rl_vs_rl_reactive (sp_rl > rl, reactive, 1.8 m/s) | success rate | +0.908 |"
            in text
        )
        assert f"+-{order['half_width']:.3f} | {order['seeds_for_80pct_power_at_margin']} |" in text
        assert "Declared but not measured by this plan: `sp_rl_vs_rl_random_reactive`" in text
        assert "| unresolved | unresolved, paper's value excluded |" in text


class TestAgainstThePaper:
    @pytest.mark.parametrize(
        "ci, paper, verdict",
        [
            ((0.80, 0.95), 0.908, "reproduced"),
            ((0.10, 0.30), 0.908, "direction reproduced, smaller"),
            ((0.10, 0.30), 0.05, "direction reproduced, larger"),
            ((-0.30, -0.10), 0.908, "contradicted"),
            ((0.10, 0.30), 0.0, "contradicted"),
            ((-0.08, 0.09), 0.908, "contradicted"),  # equivalent within 0.10
            ((-0.08, 0.09), 0.05, "reproduced"),
            ((-0.20, 0.95), 0.908, "unresolved"),
            ((-0.20, 0.40), 0.908, "unresolved, paper's value excluded"),
            ((-0.20, 0.40), None, None),
        ],
    )
    def test_each_outcome_by_hand(self, ci, paper, verdict):
        """The resolution as ``aggregate`` gives it for a t-interval: resolved where the CI
        excludes 0, equivalent where it lies inside +-0.10."""
        lo, hi = ci
        resolution = (
            "resolved"
            if lo > 0 or hi < 0
            else "equivalent within the margin"
            if -0.10 < lo and hi < 0.10
            else "unresolved"
        )
        assert against_paper(ci, paper, resolution, 0.10) == verdict

    def test_a_plan_without_a_measured_endpoint_says_so(self):
        plan = Plan(methods=METHODS, speeds_mps=(0.8,), behaviors=("reactive",))
        ordering, headroom = judge(plan, *_cells((0.8,), ("reactive",)))
        assert not any(c["role"] == "primary" for c in ordering + headroom)
        text = primary_markdown(primary_rows(plan, ordering + headroom))
        assert text.startswith("No primary endpoint in this plan's speeds")
        empty = primary_rows(Plan(primary_endpoints=()), [])
        assert primary_markdown(empty).startswith("No primary endpoint")


class TestDeclared:
    def test_plan_json_round_trips_the_endpoints_and_a_change_is_refused(self, tmp_path):
        mine = (parse_endpoint("sp_rl-rl:reactive:1.6:0.05"), parse_endpoint("headroom:circle:1.8"))
        plan = Plan(seeds=2, primary_endpoints=mine)
        check_plan(tmp_path, plan)
        recorded = json.loads((tmp_path / "plan.json").read_text())["primary_endpoints"]
        assert tuple(Endpoint.from_json(e) for e in recorded) == mine
        assert mine[0].margin == 0.05 and mine[1].claim is None
        assert tuple(parse_endpoint(e.spec) for e in PRIMARY_ENDPOINTS) == PRIMARY_ENDPOINTS
        with pytest.raises(ValueError, match="primary_endpoints"):
            check_plan(tmp_path, Plan(seeds=2))

    @pytest.mark.parametrize(
        "spec, needle",
        [
            ("sp_rl-magic:reactive:1.8", "unknown method 'magic'"),
            ("headroom:moon:1.8", "unknown behaviour 'moon'"),
            ("rl-rl:reactive:1.8", "with itself"),
            ("rl-sp_rl:reactive:1.8:0", "margin"),
        ],
    )
    def test_a_bad_endpoint_is_a_one_line_error_naming_the_field(self, spec, needle):
        with pytest.raises(ValueError) as err:
            validate_plan(Plan(quick=True, primary_endpoints=(parse_endpoint(spec),)))
        msg = str(err.value)
        assert "\n" not in msg and msg.startswith(f"--primary-endpoints {spec}") and needle in msg

    def test_a_malformed_endpoint_names_the_form(self):
        with pytest.raises(ValueError, match="WINNER-LOSER:BEHAVIOR:SPEED"):
            parse_endpoint("sp_rl-rl@reactive")


class TestGroundTruthReadingIsRecorded:
    def test_a_plan_recorded_before_the_reading_is_refused(self, tmp_path):
        check_plan(tmp_path, Plan(seeds=2))
        recorded = json.loads((tmp_path / "plan.json").read_text())
        assert recorded["ground_truth"] == "when_predicted"
        del recorded["ground_truth"]
        (tmp_path / "plan.json").write_text(json.dumps(recorded))
        for reading in ("when_predicted", "always"):
            with pytest.raises(ValueError, match=r"ground_truth \(None -> "):
                check_plan(tmp_path, Plan(seeds=2, ground_truth=reading))

    def test_a_plan_recorded_before_the_normaliser_floor_resumes_only_without_it(self, tmp_path):
        plan = Plan(seeds=2, ppo=Plan().ppo.replace(obs_min_std=0.5))
        check_plan(tmp_path, plan)
        recorded = json.loads((tmp_path / "plan.json").read_text())
        del recorded["ppo"]["obs_min_std"]
        (tmp_path / "plan.json").write_text(json.dumps(recorded))
        with pytest.raises(ValueError, match=r"ppo\.obs_min_std \(None -> 0\.5\)"):
            check_plan(tmp_path, plan)
        check_plan(tmp_path, Plan(seeds=2))
