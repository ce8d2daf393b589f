"""``dyncatch bench ppo --json`` on a tiny geometry: the keys and their consistency."""

import json

import pytest

from dyncatch.bench.ppo_bench import mlp_flops, ppo_flops_per_sample
from dyncatch.cli.main import main
from dyncatch.rl.config import PPOCfg


def test_flop_count_by_hand():
    assert mlp_flops([3, 4, 2]) == 2 * (3 * 4 + 4 * 2)
    ppo = PPOCfg(hidden_sizes=(4,), update_epochs=2)
    f = ppo_flops_per_sample(3, ppo)
    actor, critic = 2 * (3 * 4 + 4 * 3), 2 * (3 * 4 + 4 * 1)  # 48, 32
    assert f["rollout"] == actor + 2 * critic
    # forward + backward (2x) for both nets, minus the first layers' input gradients
    assert f["update"] == 2 * (3 * (actor + critic) - 2 * (2 * 3 * 4))
    assert f["total"] == f["rollout"] + f["update"]


def test_bench_ppo_json(capsys):
    tiny = ["--ppo.num-envs", "16", "--ppo.num-steps", "8", "--ppo.num-minibatches", "2"]
    argv = ["bench", "ppo", "--json", "--iterations", "1", "--ppo.hidden-sizes", "32", *tiny]
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("samples_per_s", "achieved_gflops", "gemm_peak_gflops", "fraction_of_peak"):
        assert r[key] > 0, key
    assert r["achieved_gflops"] == pytest.approx(
        r["samples_per_s"] * r["flops_per_sample"]["total"] / 1e9
    )
    assert r["fraction_of_peak"] == pytest.approx(r["achieved_gflops"] / r["gemm_peak_gflops"])
    assert r["gemm_peak_gflops"] == max(r["gemm_gflops_by_rows"].values())


def test_impossible_geometry_is_a_one_line_error(capsys):
    argv = [
        "bench",
        "ppo",
        "--ppo.num-envs",
        "10",
        "--ppo.num-steps",
        "3",
        "--ppo.num-minibatches",
        "4",
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "num_minibatches" in err
