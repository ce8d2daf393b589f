"""Seed-level inference on hand-worked numbers and on cases small enough to enumerate."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.stats

from dyncatch.evaluation.intervals import (
    holm,
    iqm,
    mean_ci,
    probability_of_improvement,
    proportion_difference,
    resolvable_difference,
    seeds_for_power,
    stratified_bootstrap_ci,
    t_quantile,
    welch,
    welch_df,
)
from dyncatch.evaluation.stats import wilson_ci95


class TestTQuantile:
    @pytest.mark.parametrize("df", range(1, 31))
    def test_matches_scipy(self, df):
        assert t_quantile(df) == pytest.approx(scipy.stats.t.ppf(0.975, df), rel=1e-12)

    @pytest.mark.parametrize(
        ("df", "table"), [(1, 12.706), (2, 4.303), (10, 2.228), (20, 2.086), (30, 2.042)]
    )
    def test_matches_the_printed_table(self, df, table):
        # Student's t table, two-sided 95 % (any statistics textbook's appendix).
        assert t_quantile(df) == pytest.approx(table, abs=5e-4)

    def test_is_wider_than_the_normal_beyond_ten_seeds(self):
        # The old table returned 1.96 for df >= 10: 2.228 / 1.96 = 1.137 at df 10.
        assert t_quantile(10) / 1.96 == pytest.approx(1.137, abs=1e-3)

    def test_mean_ci_of_three_seeds(self):
        # mean 0.96, sample sd 0.052915, t(2) = 4.3027: half = 4.3027 * 0.052915 / sqrt 3
        m, (lo, hi) = mean_ci([1.0, 0.9, 0.98])
        assert m == pytest.approx(0.96)
        assert hi - m == pytest.approx(4.3027 * 0.052915 / math.sqrt(3), rel=1e-4)
        assert mean_ci([0.5]) == (0.5, None)


class TestWelch:
    def test_satterthwaite_df_by_hand(self):
        # var 0.04 and 0.01, n 5 and 10: u = 0.008 and 0.001;
        # df = 0.009^2 / (0.008^2 / 4 + 0.001^2 / 9) = 8.1e-5 / 1.61111e-5 = 5.0276
        assert welch_df(0.04, 5, 0.01, 10) == pytest.approx(5.0276, abs=1e-4)
        # equal variances and n: df = 2n - 2
        assert welch_df(0.3, 6, 0.3, 6) == pytest.approx(10.0)
        # one side without spread: the other's n - 1
        assert welch_df(0.0, 3, 0.2, 7) == pytest.approx(6.0)

    def test_interval_and_p_value(self):
        # a: mean 6, var 1 (n 3); b: mean 5, var 1 (n 3): se = sqrt(2/3) = 0.8165, df 4,
        # t(4) = 2.7764 -> half 2.2670; t = 1.2247 -> two-sided p = 0.2879
        d = welch([5.0, 6.0, 7.0], [4.0, 5.0, 6.0])
        assert d.difference == pytest.approx(1.0)
        assert d.df == pytest.approx(4.0)
        assert d.half_width == pytest.approx(2.7764 * 0.81650, rel=1e-4)
        assert d.p_value == pytest.approx(0.2879, abs=1e-4)
        assert d.ci == pytest.approx((1.0 - 2.2670, 1.0 + 2.2670), abs=1e-3)

    def test_agrees_with_scipy_ttest(self):
        a, b = [0.9, 0.95, 0.7, 0.88], [0.5, 0.8, 0.6, 0.75, 0.4]
        ref = scipy.stats.ttest_ind(a, b, equal_var=False)
        assert welch(a, b).p_value == pytest.approx(ref.pvalue, rel=1e-10)

    def test_no_spread_at_all(self):
        assert welch([1.0, 1.0], [1.0, 1.0]).p_value == 1.0
        assert welch([1.0, 1.0], [0.5, 0.5]).p_value == 0.0

    def test_one_seed_is_refused(self):
        with pytest.raises(ValueError, match="2\\+ seeds"):
            welch([0.5], [0.4, 0.6])

    def test_pooled_episode_proportions(self):
        # 0.4 +- 1.96 * sqrt(0.09/100 + 0.25/100) = 0.4 +- 0.11429
        d = proportion_difference(0.9, 100, 0.5, 100)
        assert d.half_width == pytest.approx(0.11429, abs=1e-5)
        assert d.df == math.inf


class TestHolm:
    def test_worked_example(self):
        # p = [0.01, 0.04, 0.03, 0.005], m = 4. Sorted: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03,
        # 0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> running max 0.06. In the input's order:
        assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])

    def test_caps_at_one_and_keeps_a_single_p(self):
        assert holm([0.5, 0.6]) == pytest.approx([1.0, 1.0])
        assert holm([0.03]) == pytest.approx([0.03])
        assert holm([]).size == 0


class TestPower:
    def test_resolvable_difference_by_hand(self):
        # sd 0.2 and 0.05 at 10 seeds: se = sqrt(0.004 + 0.00025) = 0.065192;
        # df = 0.00425^2 / (0.004^2 / 9 + 0.00025^2 / 9) = 1.80625e-5 / 1.78472e-6 = 10.1206;
        # t(10.12) = 2.2257 -> 0.14510
        assert resolvable_difference(0.2, 10, 0.05, 10) == pytest.approx(0.1451, abs=2e-4)

    def test_seeds_for_power_by_hand(self):
        # sd 0.1 each, difference 0.1: the normal line gives (1.960 + 0.842)^2 * 2 = 15.70.
        # With t's at Welch df 2n - 2: n = 16 (df 30): (2.0423 + 0.8538)^2 * 2 = 16.77 > 16;
        # n = 17 (df 32): (2.0369 + 0.8530)^2 * 2 = 16.70 <= 17 -> 17 seeds per method.
        assert seeds_for_power(0.1, 0.1, 0.1) == 17

    def test_the_issues_power_line(self):
        # rl sd 0.234, sp_rl sd 0.059, difference 0.12: z's give 7.849 * 0.058237 / 0.0144
        # = 31.7; the t's add a few seeds (issue 31: "about 34").
        n = seeds_for_power(0.12, 0.234, 0.059)
        assert 32 <= n <= 36

    def test_zero_difference_is_refused(self):
        with pytest.raises(ValueError, match="infinitely"):
            seeds_for_power(0.0, 0.1, 0.1)


class TestBootstrap:
    def test_stratified_interval_against_enumeration(self):
        # Two tasks of three seeds: 3^3 x 3^3 = 729 equally likely stratified resamples.
        scores = np.array([[0.0, 2.0], [1.0, 2.0], [3.0, 8.0]])
        exact = np.array(
            [
                np.mean(np.stack([scores[list(i), 0], scores[list(j), 1]], -1))
                for i in itertools.product(range(3), repeat=3)
                for j in itertools.product(range(3), repeat=3)
            ]
        )
        lo_exact, hi_exact = np.percentile(exact, [2.5, 97.5])
        point, (lo, hi) = stratified_bootstrap_ci(scores, np.mean, reps=20_000, seed=1)
        assert point == pytest.approx(16 / 6)
        # The resample means sit on a grid of 1/6: Monte Carlo lands within a grid step.
        assert lo == pytest.approx(lo_exact, abs=1 / 6 + 1e-9)
        assert hi == pytest.approx(hi_exact, abs=1 / 6 + 1e-9)

    def test_a_task_is_never_mixed_with_another(self):
        # Each task constant: every stratified resample has the same mean -> zero width.
        scores = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
        point, (lo, hi) = stratified_bootstrap_ci(scores, np.mean, reps=200)
        assert point == lo == hi == 0.5

    def test_iqm_drops_the_tails(self):
        # 8 scores: the middle four of 0 1 2 3 4 5 6 100 are 2 3 4 5 -> 3.5
        assert iqm(np.array([[0, 1, 2, 3], [4, 5, 6, 100]]).T) == pytest.approx(3.5)

    def test_probability_of_improvement(self):
        # a beats b in every pair on task 0 (P = 1) and ties every pair on task 1 (P = 0.5)
        a = np.array([[0.9, 0.5], [0.8, 0.5]])
        b = np.array([[0.1, 0.5], [0.2, 0.5]])
        p, (lo, hi) = probability_of_improvement(a, b, reps=200)
        assert p == pytest.approx(0.75)
        assert lo == hi == pytest.approx(0.75)


class TestWilson:
    def test_zero_successes_has_zero_lower_bound(self):
        # upper = z^2 / (n + z^2) = 3.8415 / 203.8415 = 0.018846
        lo, hi = wilson_ci95(0, 200)
        assert lo == 0.0
        assert hi == pytest.approx(3.841459 / 203.841459, rel=1e-6)

    def test_all_successes_has_unit_upper_bound(self):
        lo, hi = wilson_ci95(200, 200)
        assert hi == 1.0
        assert lo == pytest.approx(200 / 203.841459, rel=1e-6)
