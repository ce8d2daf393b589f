"""``dyncatch bench ppo --json`` on a tiny geometry: hand-worked FLOPs, plausible magnitudes,
and samples/s that agree with iterations timed independently."""

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


@pytest.mark.extended  # bench figures: docs/performance.md
def test_bench_ppo_json(capsys):
    import time

    import jax

    from dyncatch.rl.train import make_train
    from dyncatch.sim.config import WorldCfg

    tiny = ["--ppo.num-envs", "16", "--ppo.num-steps", "8", "--ppo.num-minibatches", "2"]
    argv = ["bench", "ppo", "--json", "--iterations", "2", "--ppo.hidden-sizes", "32", *tiny]
    argv += ["--gemm-rows", "512"]
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    # FLOPs by hand for 13 inputs (the default observation), one hidden layer of 32,
    # 4 epochs: actor 2*(13*32 + 32*3) = 1024, critic 2*(13*32 + 32) = 896,
    # rollout 1024 + 2*896 = 2816, update 4*(3*(1024 + 896) - 2*(2*13*32)) = 16384.
    assert r["flops_per_sample"] == {"rollout": 2816, "update": 16384, "total": 19200}
    # Physically plausible: a CPU's fp32 GEMM peak is GFLOP/s to a few TFLOP/s, and whole
    # PPO iterations cannot beat it (a unit slip of 1e3 would fail here).
    assert 0.5 < r["gemm_peak_gflops"] < 20_000
    assert list(r["gemm_gflops_by_rows"]) == ["512"]
    assert 0.0 < r["fraction_of_peak"] < 1.5
    # The samples/s agree, within a factor of 5, with iterations timed here independently.
    ppo = PPOCfg(num_envs=16, num_steps=8, num_minibatches=2, hidden_sizes=(32,))
    init, iterate, _ = make_train(WorldCfg(), ppo)
    init, iterate = jax.jit(init), jax.jit(iterate)
    ts = jax.block_until_ready(iterate(init(jax.random.key(0)))[0])
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        ts, m = iterate(ts)
        jax.block_until_ready(m)
        best = min(best, time.perf_counter() - t0)
    assert 0.2 < r["samples_per_s"] / (ppo.batch_size / best) < 5.0


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
    assert main(["bench", "ppo", "--seeds", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--seeds" in err
