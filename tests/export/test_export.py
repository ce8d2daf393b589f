"""``dyncatch export``: ONNX graphs equal the JAX policy and predictor on recorded inputs,
export.json names every input slot correctly, no pickle, and no dyncatch at load time."""

import json
import os
import pickle
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import onnxruntime as ort
import pytest

from dyncatch.cli.main import main, parse
from dyncatch.export import export
from dyncatch.predictor.checkpoint import save as save_predictor
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import history_from_state
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.config import TrackerCfg
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.reproduce.presentation import reproduced_methods
from dyncatch.rl.methods import METHODS, predictor_kinds, selected, trained_methods
from dyncatch.rl.policy import load_run
from dyncatch.rl.runner import TrainRunner
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import world_to_body
from dyncatch.sim.vec import batch_reset, batch_step
from tests.cli.test_train_cli import TINY

FAST = [*TINY, "--total-steps", "64", "--eval-every", "0"]
DOC = Path(__file__).resolve().parents[2] / "docs" / "ecosystem.md"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A tiny run per trained method, a random predictor per kind (its input normalisation
    far from the identity), and every method exported by the command.

    gt_rl (which sp_fp reuses) is trained one PPO iteration by ``dyncatch train``; the
    others are the same command's runs saved before their first iteration, by the same
    runner: the files and the loader are the same, and each PPO iteration would cost a
    15 s compilation per method on 2 cores.
    """
    root = tmp_path_factory.mktemp("export")
    preds = {}
    for i, kind in enumerate(predictor_kinds(reproduced_methods())):
        pred = Predictor.for_world(PredictorCfg(kind=kind, hidden=(8,)), WorldCfg())
        params = pred.init(jax.random.key(i))
        k1, k2 = jax.random.split(jax.random.key(10 + i))
        params["in_mean"] = jax.random.normal(k1, params["in_mean"].shape)
        params["in_std"] = jax.random.uniform(k2, params["in_std"].shape, minval=0.3, maxval=3)
        preds[kind] = root / f"{kind}.safetensors"
        save_predictor(preds[kind], pred, params)
    for name in trained_methods(reproduced_methods()):
        kind = METHODS[name].predictor_kind
        argv = ["train", "--method", name, "--out", str(root / name), *FAST]
        argv += ["--predictor", str(preds[kind])] if kind else []
        if name == "gt_rl":
            assert main(argv) == 0
        else:
            runner = TrainRunner(parse(argv)[1])
            runner.save(runner.initial_state())
    for name, m in selected(reproduced_methods()).items():
        argv = ["export", str(root / m.policy_source), "--out", str(root / f"{name}_onnx")]
        if not m.trained:
            argv += ["--as-method", name, "--predictor", str(preds[m.predictor_kind])]
        assert main(argv) == 0
    return root, preds


def _load(runs, method):
    root, preds = runs
    m = METHODS[method]
    if m.trained:
        return load_run(root / method)
    return load_run(root / m.policy_source, method, preds[m.predictor_kind])


@pytest.fixture(scope="module")
def recorded(runs):
    """1000 (state, obs) pairs: 50 environments under random commands, every 5th of 100
    control steps (2 s: four camera frames, so predictor inputs are defined in some)."""
    env = JaxCatchEnv(_load(runs, "rl").world)

    @jax.jit
    def rollout(key):
        spec = env.action_spec

        def body(state, k):
            a = jax.random.uniform(k, (50, 3), minval=spec.low, maxval=spec.high)
            state, obs, *_ = batch_step(state, a, env)
            return state, (state, obs)

        k0, k1 = jax.random.split(key)
        _, traj = jax.lax.scan(body, batch_reset(k0, env, 50), jax.random.split(k1, 100))
        # An explicit size: the open plane's obstacle arrays have a zero-length axis.
        return jax.tree.map(lambda x: x[4::5].reshape(20 * 50, *x.shape[2:]), traj)

    states, obs = rollout(jax.random.key(7))
    assert obs.flat.shape[0] == 1000
    assert 0.1 < float(states.sensor.consecutive.mean()) < 0.9
    return states, obs


def _ort(path: Path, **inputs) -> np.ndarray:
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return session.run(None, {k: np.asarray(v, np.float32) for k, v in inputs.items()})[0]


@jax.jit
def _jax_policy(policy, states, obs):
    """The policy's input vectors (N, D) and ``LearnedPolicy.step``'s commands (N, 3)."""
    x = jax.vmap(policy.obs_fn)(states, obs)
    command = jax.vmap(lambda s, o: policy.step((), s, o, None)[1])(states, obs)
    return x, command


@pytest.mark.parametrize("method", list(selected(reproduced_methods())))
def test_the_graphs_equal_the_jax_policy_and_predictor(runs, recorded, method):
    root, _ = runs
    out, policy = root / f"{method}_onnx", _load(runs, method).policy
    x, command = _jax_policy(policy, *recorded)
    got = _ort(out / "policy.onnx", obs=x)
    assert got.shape == (1000, 3)
    np.testing.assert_allclose(got, command, rtol=0, atol=1e-5)
    manifest = json.loads((out / "export.json").read_text())
    assert manifest["policy"]["inputs"][0]["shape"] == ["batch", x.shape[1]]
    pred = policy.obs_fn.predictor
    assert (
        (manifest["predictor"] is None) == (pred is None) == (not (out / "predictor.onnx").exists())
    )
    if pred is not None:
        states, _ = recorded
        features, yaw = jax.vmap(pred.encode)(history_from_state(states))
        want = pred.apply_encoded(policy.obs_fn.predictor_params, features, yaw)
        got = _ort(out / "predictor.onnx", features=features, yaw_out_rad=yaw)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5)
        assert float(jnp.abs(yaw).max()) > 0.1 or pred.cfg.kind == "vanilla"


def _slices(layout, x):
    return {e["name"]: x[:, e["offset"] : e["offset"] + e["size"]] for e in layout}


def test_the_layout_names_the_slots_of_the_real_input_vectors(runs, recorded):
    root, _ = runs
    states, obs = recorded
    manifest = json.loads((root / "gt_rl_onnx" / "export.json").read_text())
    x, _ = _jax_policy(_load(runs, "gt_rl").policy, states, obs)
    named = _slices(manifest["policy"]["inputs"][0]["layout"], x)
    for name, value in named.items():
        if hasattr(obs, name):
            np.testing.assert_array_equal(value, np.asarray(getattr(obs, name)).reshape(1000, -1))
    v_world = jax.vmap(lambda target: target.vel_mps)(states.target)
    # GT-Pred is given where the predictor's input is: two consecutive sightings.
    ok = np.asarray(states.sensor.consecutive, np.float32)[:, None]
    v_body = world_to_body(v_world, states.robot.yaw_rad) * ok
    np.testing.assert_allclose(named["target_vel_body_mps"], v_body, atol=1e-6)
    np.testing.assert_array_equal(named["target_vel_defined"], ok)
    # The default input is the paper's s: no staleness inputs, so no unit "s".
    units = {e["unit"] for e in manifest["policy"]["inputs"][0]["layout"]}
    assert units >= {"m", "m/s", "rad/s"} and "s" not in units
    assert manifest["rates_hz"] == {"control": 50.0, "camera": 2.0}
    assert manifest["method"] == "gt_rl" and manifest["versions"]["opset"] == 20
    assert set(manifest["versions"]) >= {"dyncatch", "jax", "onnx"}


def test_the_documented_recipe_builds_the_predictor_methods_input(runs, recorded):
    """export.json's to_policy recipe, applied to predictor.onnx's output, gives the
    velocity slots sp_fp's policy sees; features slots mean what their names say."""
    root, _ = runs
    states, obs = recorded
    out = root / "sp_fp_onnx"
    manifest = json.loads((out / "export.json").read_text())
    policy = _load(runs, "sp_fp").policy
    pred = policy.obs_fn.predictor
    features, yaw_out = jax.vmap(pred.encode)(history_from_state(states))
    v_world = _ort(out / "predictor.onnx", features=features, yaw_out_rad=yaw_out)
    ok = np.asarray(states.sensor.consecutive, np.float32)[:, None]
    v_body = ok * np.asarray(world_to_body(jnp.asarray(v_world), states.robot.yaw_rad))
    x, _ = _jax_policy(policy, states, obs)
    named = _slices(manifest["policy"]["inputs"][0]["layout"], x)
    np.testing.assert_allclose(named["target_vel_body_mps"], v_body, atol=1e-5)
    np.testing.assert_array_equal(named["target_vel_defined"], ok)
    f = _slices(manifest["predictor"]["inputs"][0]["layout"], np.asarray(features))
    np.testing.assert_allclose(f["robot_yaw_rate_rps"][:, 0], states.robot.yaw_rate_rps)
    np.testing.assert_allclose(f["robot_vel_body_mps"], states.robot.vel_body_mps)
    dt = manifest["predictor"]["frame_dt_s"]
    d = (states.sensor.obs_xy_m - states.sensor.prev_obs_xy_m) / dt
    want = world_to_body(d, states.sensor.robot_pose[:, 2])
    np.testing.assert_allclose(f["target_vel_body_mps"], want, atol=1e-4)


def test_a_saturating_policy_is_clipped_and_scaled_as_in_jax(runs, recorded, tmp_path):
    """A policy whose mean actions leave [-1, 1] half the time: the clip and the command
    scaling are exercised, not just the small actions of a freshly trained net."""
    run = _load(runs, "rl")
    params = jax.tree.map(lambda v: v, run.policy.params)
    actor = params["params"]["actor"]
    last = max(actor, key=lambda k: int(k.split("_")[1]))
    actor[last] = jax.tree.map(lambda v: v * 50.0, actor[last])
    norm = run.policy.norm
    norm = norm.replace(mean=norm.mean + 0.5, var=norm.var * jnp.linspace(0.1, 4.0, len(norm.var)))
    run = replace(run, policy=run.policy.replace(params=params, norm=norm))
    export(run, tmp_path)
    x, command = _jax_policy(run.policy, *recorded)
    np.testing.assert_allclose(_ort(tmp_path / "policy.onnx", obs=x), command, rtol=0, atol=1e-5)
    spec = run.policy.env.action_spec
    at_bound = np.isclose(command, spec.low) | np.isclose(command, spec.high)
    assert 0.2 < at_bound.mean() < 0.8


def test_export_writes_no_pickle(runs, tmp_path, monkeypatch):
    root, _ = runs

    def refuse(*args, **kwargs):
        raise AssertionError("pickle used")

    for name in ("dump", "dumps", "Pickler"):
        monkeypatch.setattr(pickle, name, refuse)
    with pytest.raises(AssertionError, match="pickle used"):
        pickle.dumps(1)  # the patch is live
    assert main(["export", str(root / "sp_rl"), "--out", str(tmp_path / "x")]) == 0
    files = ["export.json", "policy.onnx", "predictor.onnx"]
    assert sorted(p.name for p in (tmp_path / "x").iterdir()) == files
    # Exporting a method without a predictor into the same folder leaves no stale one.
    assert main(["export", str(root / "rl"), "--out", str(tmp_path / "x")]) == 0
    assert sorted(p.name for p in (tmp_path / "x").iterdir()) == files[:2]


def _isolated(code: str, cwd: Path) -> str:
    """Run ``code`` in ``python -I`` (no PYTHONPATH, no user site), return its stdout."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run(
        [sys.executable, "-I", "-c", code], cwd=cwd, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


LOADER = """
import json, sys
import numpy as np, onnxruntime as ort
run = lambda f, **x: ort.InferenceSession(f).run(None, x)[0]
np.save("command.npy", run("x/policy.onnx", obs=np.load("obs.npy")))
np.save("v.npy", run("x/predictor.onnx", features=np.load("f.npy"), yaw_out_rad=np.load("y.npy")))
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in ("dyncatch", "jax"))))
"""


def test_the_files_load_with_onnxruntime_and_numpy_only(runs, recorded, tmp_path):
    root, _ = runs
    states, obs = recorded
    policy = _load(runs, "sp_rl").policy
    x, command = _jax_policy(policy, states, obs)
    features, yaw = jax.vmap(policy.obs_fn.predictor.encode)(history_from_state(states))
    for name, value in (("obs", x), ("f", features), ("y", yaw)):
        np.save(tmp_path / f"{name}.npy", np.asarray(value, np.float32))
    (tmp_path / "x").symlink_to(root / "sp_rl_onnx")
    assert json.loads(_isolated(LOADER, tmp_path)) == []
    np.testing.assert_allclose(np.load(tmp_path / "command.npy"), command, atol=1e-5)
    want = policy.obs_fn.predictor.apply_encoded(policy.obs_fn.predictor_params, features, yaw)
    np.testing.assert_allclose(np.load(tmp_path / "v.npy"), want, atol=1e-5)


def test_the_documented_example_runs_and_gives_the_policy_command(runs, tmp_path):
    """docs/ecosystem.md's example (at most 20 lines), run as written, isolated."""
    root, _ = runs
    section = DOC.read_text().split("## Deployable policies (ONNX)")[1].split("\n## ")[0]
    (example,) = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(example.strip().splitlines()) <= 20
    (tmp_path / "exported").symlink_to(root / "gt_rl_onnx")
    check = "\nprint(json.dumps(command.tolist()))\n"
    command = json.loads(_isolated(example + check, tmp_path).splitlines()[-1])
    policy = _load(runs, "gt_rl").policy
    zeros = jnp.zeros(policy.norm.mean.shape[0])  # the example's all-zero readings
    # The JAX policy's own step (network, normaliser, command scaling) on that input.
    _, want = policy.replace(obs_fn=_Given(zeros)).step((), None, None, None)
    np.testing.assert_allclose(command, want, atol=1e-5)
    spec = policy.env.action_spec
    assert np.all(np.asarray(spec.low) <= command) and np.all(command <= np.asarray(spec.high))


class _Given:
    """An input function that hands the policy ``x`` whatever the state."""

    def __init__(self, x):
        self.x = x

    def step(self, carry, state, obs):
        del state, obs
        return carry, self.x


def test_bad_input_is_a_one_line_error(runs, tmp_path, capsys):
    root, preds = runs
    not_a_run = tmp_path / "empty"
    not_a_run.mkdir()
    cases = [
        (["export", str(not_a_run), "--out", str(tmp_path / "o")], "dyncatch train"),
        (
            ["export", str(root / "gt_rl"), "--out", str(tmp_path / "o"), "--as-method", "sp_fp"],
            "--predictor",
        ),
        (
            [
                "export",
                str(root / "gt_rl"),
                "--out",
                str(tmp_path / "o"),
                "--as-method",
                "sp_fp",
                "--predictor",
                str(tmp_path / "missing.safetensors"),
            ],
            "train one first",
        ),
        (
            ["export", str(root / "rl"), "--out", str(tmp_path / "o"), "--as-method", "sp_fp"],
            "cannot be evaluated as",
        ),
    ]
    tracker = Tracker.for_world(TrackerCfg(hidden=(8,)), WorldCfg())
    save_predictor(tmp_path / "tracker.safetensors", tracker, tracker.init(jax.random.key(0)))
    cases.append(
        (
            [
                *["export", str(root / "gt_rl"), "--out", str(tmp_path / "o")],
                *["--as-method", "st_fp", "--predictor", str(tmp_path / "tracker.safetensors")],
            ],
            "carries a memory",
        )
    )
    for argv, needle in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and needle in err, (argv, err)
    assert not (tmp_path / "o").exists()
