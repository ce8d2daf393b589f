"""``rnn_rl`` end to end at the command line (train, eval, export) and its ONNX graph, hidden
state in and out, equal to the JAX policy over a recorded 20 s episode: the graph fed back
its own ``memory_out``, as a robot runs it."""

import json
from dataclasses import replace
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import onnxruntime as ort
import pytest

from dyncatch.cli.main import main
from dyncatch.export import export
from dyncatch.predictor.checkpoint import save as save_predictor
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.rl.policy import load_run
from dyncatch.rl.recurrent import MemoryPolicy
from dyncatch.sim.config import WorldCfg
from tests.export.test_export import FAST

N_ENVS = 8


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A one-iteration ``rnn_rl`` run, evaluated and exported by the commands."""
    root = tmp_path_factory.mktemp("rnn")
    assert main(["train", "--method", "rnn_rl", "--out", str(root / "run"), *FAST]) == 0
    argv = ["eval", str(root / "run"), "--speeds", "0.8", "--episodes", "8", "--json"]
    assert main(argv) == 0
    assert main(["export", str(root / "run"), "--out", str(root / "onnx")]) == 0
    return root


@partial(jax.jit, static_argnums=1)
def _episode(policy: MemoryPolicy, steps: int):
    """One 20 s episode in each of ``N_ENVS`` environments as evaluation plays it: the
    policy's inputs (T, N, D), hidden states after each step (T, N, H), commands (T, N, 3)."""
    env = policy.env
    state = jax.vmap(env.reset)(jax.random.split(jax.random.key(5), N_ENVS))
    obs = jax.vmap(env.observe)(state)
    carry = jax.vmap(policy.init_carry)(state, obs)

    def body(c, _):
        state, obs, carry = c
        _, x = jax.vmap(policy.obs_fn.step)(carry[0], state, obs)
        carry, command = jax.vmap(policy.step)(carry, state, obs, jnp.zeros(N_ENVS))
        state, obs, *_ = jax.vmap(env.step)(state, command)
        return (state, obs, carry), (x, carry[1], command)

    _, out = jax.lax.scan(body, (state, obs, carry), None, length=steps)
    return out


def _parity(policy: MemoryPolicy, path) -> tuple[np.ndarray, np.ndarray]:
    """Step the graph through the recorded episode on its own memory; returns the commands
    and the hidden states."""
    steps = int(policy.env.world.episode.max_steps)
    x, memory, command = map(np.asarray, _episode(policy, steps))
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    h = np.zeros((N_ENVS, policy.net.memory_size), np.float32)
    for t in range(x.shape[0]):
        got, h = session.run(None, {"obs": x[t].astype(np.float32), "memory_in": h})
        np.testing.assert_allclose(got, command[t], rtol=0, atol=1e-5, err_msg=f"step {t}")
        np.testing.assert_allclose(h, memory[t], rtol=0, atol=1e-5, err_msg=f"step {t}")
    assert x.shape[0] == 1000
    return command, memory


def test_the_graph_equals_the_jax_policy_over_an_episode_hidden_state_included(run):
    policy = load_run(run / "run").policy
    assert isinstance(policy, MemoryPolicy)
    _parity(policy, run / "onnx" / "policy.onnx")
    manifest = json.loads((run / "onnx" / "export.json").read_text())
    h = policy.net.memory_size
    assert [i["name"] for i in manifest["policy"]["inputs"]] == ["obs", "memory_in"]
    assert [o["name"] for o in manifest["policy"]["outputs"]] == ["command", "memory_out"]
    assert (
        manifest["policy"]["inputs"][1]["shape"] == ["batch", h] and manifest["method"] == "rnn_rl"
    )


def test_a_policy_that_saturates_and_remembers_strongly_matches_too(run, tmp_path):
    """Larger weights than one iteration gives: commands at their limits part of the time and
    a GRU whose state moves far from zero, so the clip, the scaling and the gates are
    exercised over the 1000 steps. (At 200x the actor's weights float32 rounding of the
    state alone moves a command by 1e-5: the tolerance is a statement about rounding.)"""
    loaded = load_run(run / "run")
    params = jax.tree.map(lambda v: v, loaded.policy.params)
    p = params["params"]
    p["actor"] = jax.tree.map(lambda v: v * 50.0, p["actor"])
    p["actor_memory"] = jax.tree.map(lambda v: v * 3.0, p["actor_memory"])
    norm = loaded.policy.norm
    norm = norm.replace(mean=norm.mean + 0.5, var=norm.var * jnp.linspace(0.1, 4, len(norm.var)))
    loaded = replace(loaded, policy=loaded.policy.replace(params=params, norm=norm))
    export(loaded, tmp_path)
    command, memory = _parity(loaded.policy, tmp_path / "policy.onnx")
    spec = loaded.policy.env.action_spec
    at_bound = np.isclose(command, spec.low) | np.isclose(command, spec.high)
    # Measured: 7 % of the command entries at a limit, the hidden state's mean |h| 0.84.
    assert 0.03 < at_bound.mean() < 0.97
    assert np.abs(memory).mean() > 0.3


def test_rnn_sp_rl_trains_with_the_predictor_and_exports_both_graphs(tmp_path):
    """The same memory on sp_rl's input: one iteration at the command line, loaded as a
    memory policy reading the predictor, exported as the recurrent policy plus predictor."""
    pred = Predictor.for_world(PredictorCfg(kind="self_aware", hidden=(8,)), WorldCfg())
    save_predictor(tmp_path / "p.safetensors", pred, pred.init(jax.random.key(0)))
    run, out = tmp_path / "run", tmp_path / "onnx"
    argv = ["train", "--method", "rnn_sp_rl", "--out", str(run), *FAST]
    assert main([*argv, "--predictor", str(tmp_path / "p.safetensors")]) == 0
    policy = load_run(run).policy
    assert isinstance(policy, MemoryPolicy) and policy.obs_fn.velocity_input == "self_aware"
    assert main(["export", str(run), "--out", str(out)]) == 0
    manifest = json.loads((out / "export.json").read_text())
    assert manifest["predictor"]["kind"] == "self_aware" and (out / "predictor.onnx").exists()
    assert [i["name"] for i in manifest["policy"]["inputs"]] == ["obs", "memory_in"]
    _parity(policy, out / "policy.onnx")
