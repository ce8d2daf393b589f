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


def _with_cells(results: dict, sp_rl: list[float], rl: list[float]) -> dict:
    results["plan"]["primary_endpoints"] = [
        {"name": "sp_rl_vs_rl_reactive", "kind": "ordering", "behavior": "reactive",
         "speed_mps": 1.8, "claim": ["sp_rl", "rl"], "metric": "success_rate", "margin": 0.1},
        {"name": "oracle_headroom_reactive", "kind": "headroom", "behavior": "reactive",
         "speed_mps": 1.8, "claim": None, "metric": "success_rate", "margin": 0.1},
    ]  # fmt: skip
    cells = [
        {"method": m, "behavior": "reactive", "speed_mps": 1.8, "episodes": 300 * len(p),
         "per_seed_success": p, "success_rate": sum(p) / len(p)}
        for m, p in (("sp_rl", sp_rl), ("rl", rl))
    ]  # fmt: skip
    results["table_i"] = {"cells": cells}
    return results


def test_pooled_judges_the_ordering_endpoints_on_both_sets_seeds():
    """The pooled interval is Welch's over the union of both sets' seeds (scipy's
    Welch test gives the same p-value); the headroom endpoint is left out."""
    import numpy as np
    import scipy.stats

    from dyncatch.reproduce.replication import pooled, pooled_markdown

    rng = np.random.default_rng(0)
    s1, r1, s2, r2 = (rng.uniform(lo, 1.0, 10).round(3).tolist() for lo in (0.7, 0.2, 0.7, 0.2))
    a = _with_cells(_results(0, 0.1, 0.0, 0.2, "resolved"), s1, r1)
    b = _with_cells(_results(10, 0.1, 0.0, 0.2, "resolved"), s2, r2)
    [row] = pooled(a, b)
    sp, r = s1 + s2, r1 + r2
    assert row["seeds"] == [20, 20] and row["sets"] == ["0-9", "10-19"]
    assert row["difference"] == pytest.approx(np.mean(sp) - np.mean(r))
    assert row["p_value"] == pytest.approx(scipy.stats.ttest_ind(sp, r, equal_var=False).pvalue)
    assert row["role"] == "primary" and row["resolution"] == "resolved"
    assert row["smallest_resolvable_difference"] == pytest.approx(row["half_width"])
    assert "| 20 (0-9 + 10-19) |" in pooled_markdown([row])
    with pytest.raises(ValueError, match="share seeds"):
        pooled(a, _with_cells(_results(5, 0.1, 0.0, 0.2, "resolved"), s2, r2))


def test_a_rounding_only_field_may_differ_and_is_reported():
    a = _results(0, 0.12, 0.03, 0.21, "resolved")
    a["plan"]["vmap_seeds"] = True
    b = _results(10, 0.09, 0.01, 0.17, "resolved")
    b["plan"]["vmap_seeds"] = False
    [row] = compare(a, b)
    assert row["agree"] and row["rounding_only_differences"] == ["vmap_seeds: True/False"]
    assert (
        compare(a, copy.deepcopy(a) | {"plan": {**a["plan"], "first_seed": 10}})[0][
            "rounding_only_differences"
        ]
        == []
    )


def test_a_set_trained_in_parts_merges_into_the_set_it_would_have_been():
    """Two halves of seeds 10-19 merged judge the endpoint on the ten seeds together, as
    pooling them does; the merged set then compares and pools like one run's."""
    import numpy as np

    from dyncatch.reproduce.replication import merged, pooled

    rng = np.random.default_rng(1)
    s, r = (rng.uniform(lo, 1.0, 20).round(3).tolist() for lo in (0.7, 0.2))
    a = _with_cells(_results(0, 0.1, 0.0, 0.2, "resolved"), s[:10], r[:10])
    halves = []
    for first, sl in ((10, slice(10, 15)), (15, slice(15, 20))):
        h = _with_cells(_results(first, 0.1, 0.0, 0.2, "resolved"), s[sl], r[sl])
        h["plan"]["seeds"] = 5
        halves.append(h)
    b = merged(*halves)
    assert b["plan"]["seed_list"] == list(range(10, 20)) and b["merged_from"] == ["10-14", "15-19"]
    [row_b] = b["primary_endpoints"]["measured"]
    assert row_b["seeds"] == [10, 10]
    assert row_b["difference"] == pytest.approx(np.mean(s[10:]) - np.mean(r[10:]))
    [row] = compare(a, b)
    assert row["sets"] == ["0-9", "10-14 + 15-19"]
    [p2] = pooled(a, b)
    [p3] = pooled(a, *halves)
    assert p2["difference"] == pytest.approx(p3["difference"]) and p3["seeds"] == [20, 20]
    assert p3["sets"] == ["0-9", "10-14", "15-19"]
    with pytest.raises(ValueError, match="share seeds"):
        merged(halves[0], halves[0])


def test_a_part_of_the_plan_compares_and_pools_on_its_behaviours_endpoints():
    """A second set run as the reactive part of the plan (``--part reactive``) is judged
    against the first on the reactive endpoint alone; another plan is still refused."""
    import dataclasses

    import numpy as np

    from dyncatch.reproduce.parts import part_plan
    from dyncatch.reproduce.plan import PROFILES
    from dyncatch.reproduce.replication import pooled

    whole = dataclasses.replace(PROFILES["power"], seeds=10)
    part = dataclasses.replace(part_plan(whole, "reactive"), seeds=5, first_seed=10)
    rng = np.random.default_rng(2)
    s, r = (rng.uniform(lo, 1.0, 15).round(3).tolist() for lo in (0.7, 0.2))
    a = _with_cells(_results(0, 0.1, 0.0, 0.2, "resolved"), s[:10], r[:10])
    b = _with_cells(_results(10, 0.1, 0.01, 0.2, "resolved"), s[10:], r[10:])
    a["plan"], b["plan"] = whole.to_json(), {**part.to_json(), "vmap_seeds": True}
    [row] = compare(a, b)
    assert row["behavior"] == "reactive" and row["sets"] == ["0-9", "10-14"] and row["agree"]
    [p] = pooled(a, b)
    assert p["behavior"] == "reactive" and p["seeds"] == [15, 15]
    assert p["difference"] == pytest.approx(np.mean(s) - np.mean(r))
    b["plan"]["episodes"] = 1000
    with pytest.raises(ValueError, match="different plans"):
        compare(a, b)


def test_a_part_recorded_before_a_field_existed_is_still_a_part_of_the_plan():
    """A field added since (``world.base.max_speed_mps``) is missing from an older part's
    plan.json: at the value the code had before it, the part compares; at another, the
    plans differ."""
    import dataclasses

    from dyncatch.reproduce.parts import part_plan
    from dyncatch.reproduce.plan import PROFILES

    whole = dataclasses.replace(PROFILES["power"], seeds=10)
    part = dataclasses.replace(part_plan(whole, "reactive"), seeds=5, first_seed=10)
    a = _with_cells(_results(0, 0.1, 0.0, 0.2, "resolved"), [0.9] * 10, [0.5, 0.6] * 5)
    b = _with_cells(_results(10, 0.1, 0.0, 0.2, "resolved"), [0.8] * 5, [0.4, 0.7, 0.6, 0.5, 0.3])
    a["plan"], b["plan"] = whole.to_json(), part.to_json()
    del b["plan"]["world"]["base"]["max_speed_mps"]
    assert compare(a, b)[0]["sets"] == ["0-9", "10-14"]
    del a["plan"]["world"]["base"]["max_speed_mps"]  # both older: one plan still
    assert compare(a, b)[0]["sets"] == ["0-9", "10-14"]
    a["plan"]["world"]["base"]["max_speed_mps"] = 1.5
    with pytest.raises(ValueError, match=r"different plans \(.*world\)"):
        compare(a, b)


def test_a_merged_set_names_for_each_endpoint_the_parts_that_measured_it():
    """Seeds 10-14 measured both behaviours, seeds 15-19 reactive alone (a part): the
    random_reactive endpoint is the first half's, and says so."""
    from dyncatch.reproduce.replication import merged, pooled

    def both(results, s, r, s2, r2):
        results = _with_cells(results, s, r)
        rr = copy.deepcopy(results["plan"]["primary_endpoints"][0])
        rr.update(name="sp_rl_vs_rl_random_reactive", behavior="random_reactive")
        results["plan"]["primary_endpoints"].append(rr)
        row = copy.deepcopy(results["primary_endpoints"]["measured"][0])
        row.update(endpoint="sp_rl_vs_rl_random_reactive", behavior="random_reactive")
        results["primary_endpoints"]["measured"].append(row)
        results["table_i"]["cells"] += [
            {**c, "behavior": "random_reactive", "per_seed_success": p}
            for c, p in zip(results["table_i"]["cells"], (s2, r2), strict=True)
        ]
        return results

    s, r = [0.9, 0.8, 0.95, 0.85, 0.9], [0.5, 0.7, 0.4, 0.6, 0.3]
    a = both(_results(0, 0.1, 0.0, 0.2, "resolved"), s * 2, r * 2, s * 2, r * 2)
    h1 = both(_results(10, 0.1, 0.0, 0.2, "resolved"), s, r, s, r)
    h2 = _with_cells(_results(15, 0.1, 0.0, 0.2, "resolved"), s, r)
    h2["plan"]["primary_endpoints"] = h1["plan"]["primary_endpoints"]
    for h in (h1, h2):
        h["plan"]["seeds"] = 5
    b = merged(h1, h2)
    sets = {row["behavior"]: row["sets"] for row in b["primary_endpoints"]["measured"]}
    assert sets == {"reactive": ["10-14", "15-19"], "random_reactive": ["10-14"]}
    rows = {row["behavior"]: row for row in compare(a, b)}
    assert rows["random_reactive"]["sets"] == ["0-9", "10-14"]
    assert rows["reactive"]["sets"] == ["0-9", "10-14 + 15-19"]
    pooled_sets = {row["behavior"]: (row["sets"], row["seeds"]) for row in pooled(a, b)}
    assert pooled_sets["random_reactive"] == (["0-9", "10-14"], [15, 15])
    assert pooled_sets["reactive"] == (["0-9", "10-14 + 15-19"], [20, 20])
