"""Seeds in one jit: ``dyncatch train --seeds S`` trains S seeds as one vmap-ped
computation, and each seed's run equals its separate run to float tolerance.

Not bit for bit: on XLA:CPU a ``vmap``-ped matrix product is one batched product whose sums
may run in another order (measured: parameters differ by <= 6e-8 after 3 iterations, losses
by ~1e-7 relative). The random streams are identical (the same keys), so the episode counts,
successes and env steps are equal exactly over a short run.
"""

import csv
import os
import subprocess
import sys

import jax
import numpy as np
import pytest

from dyncatch.cli.main import main
from dyncatch.rl.runner import CHECKPOINT, TrainRunCfg, TrainRunner, seed_cfgs
from dyncatch.rl.seeds import SeedGroupRunner
from dyncatch.utils.tree_io import load_tree

TINY = [
    "--method", "rl",
    "--behavior", "bounce",
    "--ppo.num-envs", "16",
    "--ppo.num-steps", "8",
    "--ppo.num-minibatches", "2",
    "--ppo.update-epochs", "2",
    "--ppo.hidden-sizes", "32",
    "--checkpoint-every", "1",
    "--eval-every", "2",
    "--eval-episodes", "4",
    "--world.episode.duration-s", "1.0",
    "--logger", "csv",
]  # fmt: skip
EXACT = ("iteration", "env_steps", "episodes", "success_rate", "episode_length_s")
"""Columns that count events: equal exactly (the same keys draw the same noise)."""
TIMES = ("time_s",)
"""The wall clock: a group's seeds share it, so it differs from a separate run's."""


def _rows(path):
    with (path / "metrics.csv").open() as f:
        return list(csv.DictReader(f))


def _assert_same_run(a, b, iterations=None):
    ra, rb = _rows(a)[:iterations], _rows(b)[:iterations]
    assert [r["iteration"] for r in ra] == [r["iteration"] for r in rb]
    for x, y in zip(ra, rb, strict=True):
        for k in x:
            if k in TIMES:
                continue
            if k in EXACT or x[k] == "":
                assert x[k] == y[k], k
            else:
                assert float(x[k]) == pytest.approx(float(y[k]), rel=1e-4, abs=1e-6), k
    if iterations is not None:
        return  # the checkpoints are at different iterations
    ta, ha = _load(a)
    tb, hb = _load(b)
    assert ha == hb
    for x, y in zip(jax.tree.leaves(ta.params), jax.tree.leaves(tb.params), strict=True):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=1e-4, atol=1e-6)


def _load(run):
    from dyncatch.cli.main import parse

    cfg = parse(["train", *TINY, "--out", str(run), "--seed", "4"])[1]
    runner = TrainRunner(cfg)
    return load_tree(run / CHECKPOINT, jax.eval_shape(runner._init, jax.random.key(0)))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("seeds")
    group, single = root / "group", root / "single"
    assert main(["train", *TINY, "--seeds", "2", "--seed", "3", "--total-steps", "256", "--out",
                 str(group)]) == 0  # fmt: skip
    assert main(["train", *TINY, "--seed", "4", "--total-steps", "256", "--out", str(single)]) == 0
    return group, single


def test_a_seed_of_a_group_equals_its_separate_run(runs):
    group, single = runs
    assert sorted(p.name for p in group.iterdir()) == ["seed3", "seed4"]
    assert [r["iteration"] for r in _rows(group / "seed4")] == ["1", "2"]
    _assert_same_run(group / "seed4", single)
    # The two seeds of the group are different runs.
    assert _rows(group / "seed3")[-1]["loss/value"] != _rows(group / "seed4")[-1]["loss/value"]


SHARDED = """
import sys, jax
from dyncatch.cli.main import main, parse
from dyncatch.rl.seeds import make_runner

assert jax.device_count() == 2, jax.devices()
assert main(sys.argv[1:]) == 0
# The state is split over both devices, and the update sums gradients across them.
runner = make_runner(parse([*sys.argv[1:-2], "--out", "{out}/check"])[1])
init, iterate, _ = runner._compiled(2)
ts = init(jax.random.split(jax.random.key(0), 2))
obs = jax.tree.leaves(ts.obs)[0]  # (seeds, num_envs, ...)
assert len(obs.sharding.device_set) == 2, obs.sharding
assert obs.addressable_shards[0].data.shape[1] == obs.shape[1] // 2
assert "all-reduce" in iterate.lower(ts).compile().as_text()
"""


def test_a_run_resumed_at_its_end_reports_its_last_metrics(runs):
    """Nothing is left to train: the final metrics (reproduce's done.json) are the last
    logged row, for a group and for a single run, and no row is added."""
    from dyncatch.cli.main import parse
    from dyncatch.rl.seeds import make_runner

    group, single = runs
    for out, extra in ((group, ["--seeds", "2", "--seed", "3"]), (single, ["--seed", "4"])):
        argv = ["train", *TINY, *extra, "--total-steps", "256", "--out", str(out), "--resume"]
        got = make_runner(parse(argv)[1]).learn()
        dirs = [out / "seed3", out / "seed4"] if out == group else [out]
        finals = got if out == group else [got]
        for d, final in zip(dirs, finals, strict=True):
            last = _rows(d)[-1]
            assert len(_rows(d)) == 2 and final
            assert final == {k: float(v) for k, v in last.items() if v}


@pytest.mark.extended  # a cold 2-device process (50 s); sharded code runs on 1 device everywhere
def test_two_devices_give_the_metrics_of_one(runs, tmp_path):
    """The environment batch and the PPO minibatches split over 2 (forced host) devices:
    the same runs to float tolerance (only the order of the cross-device sums differs)."""
    group, _ = runs
    out = tmp_path / "sharded"
    flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2"
    code = SHARDED.format(out=str(out))
    argv = ["train", *TINY, "--seeds", "2", "--seed", "3", "--total-steps", "256"]
    env = {**os.environ, "XLA_FLAGS": flags, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(
        [sys.executable, "-c", code, *argv, "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    for seed in ("seed3", "seed4"):
        _assert_same_run(out / seed, group / seed, iterations=2)


def test_an_uneven_split_is_refused_naming_the_flag():
    from dyncatch.rl.config import PPOCfg
    from dyncatch.rl.sharding import validate_mesh

    with pytest.raises(ValueError, match="--ppo.num-envs"):
        validate_mesh(PPOCfg(num_envs=15, num_steps=8, num_minibatches=1), 2)
    with pytest.raises(ValueError, match="--ppo.num-minibatches"):
        validate_mesh(PPOCfg(num_envs=16, num_steps=1, num_minibatches=16), 2)
    validate_mesh(PPOCfg(num_envs=16, num_steps=8, num_minibatches=2), 2)


@pytest.mark.extended  # resume: tests/rl/test_resume.py
def test_a_group_resumes_and_a_resumed_seed_still_equals_its_separate_run(runs):
    group, single = runs
    args = [*TINY, "--total-steps", "512"]
    assert main(["train", *args, "--seeds", "2", "--seed", "3", "--out", str(group),
                 "--resume"]) == 0  # fmt: skip
    assert main(["train", *args, "--seed", "4", "--out", str(single), "--resume"]) == 0
    assert [r["iteration"] for r in _rows(group / "seed3")] == ["1", "2", "3", "4"]
    _assert_same_run(group / "seed4", single)


def test_seed_groups_are_checked_at_the_boundary(tmp_path, capsys):
    cfg = TrainRunCfg(method="rl", seeds=3, seed=5, out=tmp_path)
    assert [(c.seed, c.out.name, c.seeds) for c in seed_cfgs(cfg)] == [
        (5, "seed5", 1),
        (6, "seed6", 1),
        (7, "seed7", 1),
    ]
    a, b = seed_cfgs(cfg)[:2]
    with pytest.raises(ValueError, match="differ only in seed"):
        SeedGroupRunner([a, TrainRunCfg(method="gt_rl", seed=6, out=b.out)])
    with pytest.raises(ValueError, match="distinct seeds"):
        SeedGroupRunner([a, a])
    assert main(["train", *TINY, "--seeds", "0", "--out", str(tmp_path / "x")]) == 2
    assert "--seeds" in capsys.readouterr().err


STACKED = """
import jax, numpy as np
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.seeds import stacked_init
from dyncatch.rl.train import make_train
from dyncatch.sim.config import WorldCfg

init, _, _ = make_train(WorldCfg(), PPOCfg(num_envs=16, num_steps=8))  # default networks
keys = jax.random.split(jax.random.key(0), 2)
group = stacked_init(init)(keys)
alone = jax.jit(init)(keys[1])
raw = lambda x: jax.random.key_data(x) if jax.dtypes.issubdtype(x.dtype, jax.dtypes.prng_key) else x
for g, a in zip(jax.tree.leaves(group), jax.tree.leaves(alone), strict=True):
    assert np.array_equal(np.asarray(raw(g[1])), np.asarray(raw(a)))
print("ok")
"""


def test_a_group_of_the_default_networks_starts_as_its_seeds_would():
    """A group's starting state is each seed's own init, bit for bit. In a subprocess with
    a time limit: vmap(init) of the default networks never returned on 2 cores (a batched
    QR deadlocking XLA:CPU's pool; rl.seeds.stacked_init), and a hang must fail, not stall."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(
        [sys.executable, "-c", STACKED], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]
