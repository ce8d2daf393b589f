"""Evaluation compiles once per (method, scene): seeds (policy parameters), speeds and the
blend flag are arguments of one program, and that program plays the very episodes the
per-cell programs play, bit for bit."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.evaluation.episodes import run_episodes, run_episodes_at_speeds
from dyncatch.policies.blend import Blended, deploy
from dyncatch.policies.registry import BASELINES
from dyncatch.rl.methods import method_obs
from dyncatch.rl.networks import ActorCritic
from dyncatch.rl.normalize import RunningNorm
from dyncatch.rl.policy import LearnedPolicy
from dyncatch.sim.api import JaxCatchEnv, obs_dim
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.compiles import compile_log

PLANE = WorldCfg().with_behavior("reactive")
PLANE = PLANE.replace(episode=PLANE.episode.replace(duration_s=2.0))
ROOM = PLANE.with_scene("room_4")
SEEDS, SPEEDS, BLEND, EPISODES, TOL_M = (0, 1), (0.6, 1.8), (False, True), 8, 1e-3


def untrained(seed: int, world: WorldCfg = PLANE) -> LearnedPolicy:
    """A learned policy's structure with seed-dependent initial weights: what matters here
    is that its parameters are leaves, as a trained run's are."""
    net = ActorCritic(3, (16, 16), 0.0)
    d = obs_dim(world)
    params = net.init(jax.random.key(seed), jnp.zeros((1, d)))
    norm = RunningNorm.create(d, 0.5)
    return LearnedPolicy(net, params, norm, method_obs("rl"), JaxCatchEnv(world))


def _last_bits(got, want, err_msg):
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=0, err_msg=err_msg)


def _cells():
    return [(s, v, b) for s in SEEDS for v in SPEEDS for b in BLEND]


@pytest.fixture(scope="module")
def shared():
    """Every cell of the grid through the shared program, and its compilations."""
    out = {}
    with compile_log() as log:
        for s, v, b in _cells():
            policy = deploy(untrained(s), PLANE, ROOM, b, blend_as_flag=True)
            world = ROOM.with_speed(v)
            out[s, v, b] = jax.device_get(
                run_episodes(policy, jax.random.key(7), world, EPISODES, contact_tol_m=TOL_M)
            )
    return out, log


def test_a_grid_of_seeds_speeds_and_blend_compiles_the_program_once(shared):
    _, log = shared
    assert len(log.of("_run_impl")) == 1


def test_the_shared_program_plays_the_per_cell_episodes_bit_for_bit(shared):
    out, _ = shared
    blended_somewhere = False
    for s, v, b in _cells():
        policy = deploy(untrained(s), PLANE, ROOM, b)  # the per-cell program: plain or blended
        assert isinstance(policy, Blended) == b
        world = ROOM.with_speed(v)
        old = jax.device_get(
            run_episodes(policy, jax.random.key(7), world, EPISODES, contact_tol_m=TOL_M)
        )
        for k in ("success", "catch_time_s", "contacts"):
            np.testing.assert_array_equal(out[s, v, b][k], old[k], err_msg=f"{k} at {s, v, b}")
        # The return, which no table reports, is a sum of 100 rewards: XLA:CPU fuses the
        # reward's products and sums differently around the cond's branch than in the
        # always-blended program, so a blended cell's may differ in its last bit.
        assert_return = np.testing.assert_array_equal if not b else _last_bits
        assert_return(out[s, v, b]["return"], old["return"], err_msg=f"return at {s, v, b}")
        blended_somewhere |= b and not np.array_equal(old["return"], out[s, v, False]["return"])
    # The flag acts: some blended cell differs from its plain twin.
    assert blended_somewhere


def test_table_i_seeds_and_speeds_compile_once():
    keys = jax.random.split(jax.random.key(3), len(SPEEDS))
    with compile_log() as log:
        outs = [
            jax.device_get(run_episodes_at_speeds(untrained(s), keys, PLANE, SPEEDS, EPISODES))
            for s in SEEDS
        ]
    assert len(log.of("_run_speeds_impl")) == 1
    assert outs[0]["success"].shape == (len(SPEEDS), EPISODES)
    assert not np.array_equal(outs[0]["return"], outs[1]["return"])  # the seeds differ


def test_a_hashable_policy_keeps_the_blend_a_static_choice():
    """A scripted baseline is a compile-time constant (its world is folded into the program,
    as before); its flag is a Python bool and each value is its own program."""
    pursuit = BASELINES["pursuit"](ROOM)
    on, off = (deploy(pursuit, None, ROOM, b, blend_as_flag=True) for b in (True, False))
    assert (on.on, off.on) == (True, False) and not on.is_pytree_policy
    hash(on)
