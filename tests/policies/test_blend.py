"""Eq. 10's collision-avoidance blend: g's weights, pi_collid's corridor steering and the
policy wrapper, against hand-worked values."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.api import as_recurrent
from dyncatch.policies.blend import (
    BlendCfg,
    CollidCfg,
    blend_weights,
    blended,
    collid_action,
    collid_scan_m,
    corridor_free_m,
    plane_scan,
)
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim import env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scan import robot_clearance_m

from ..sim.helpers import place


class TestWeights:
    @pytest.mark.parametrize(
        ("d_m", "w_c"),
        [
            (math.inf, 0.0),  # the open plane: pure pi_catch
            (3.0, 0.0),
            (1.0, 0.0),  # the onset
            (0.55, 0.45),  # half way down the ramp: 0.9 * (1 - 0.55) / (1 - 0.1)
            (0.1, 0.9),  # full weight
            (0.0, 0.9),  # contact: mostly pi_collid
        ],
    )
    def test_hand_worked(self, d_m, w_c):
        w_p, got = blend_weights(jnp.float32(d_m), BlendCfg())
        assert float(got) == pytest.approx(w_c, abs=1e-6)
        assert float(w_p) == pytest.approx(1.0 - w_c, abs=1e-6)


class TestCorridor:
    rays = 2.0 * np.pi * np.arange(8) / 8

    def test_a_point_ahead(self):
        # One point 2 m ahead; 8 rays. A disc of 0.5 m meets it after 1.5 m going ahead;
        # at 45 deg the point is 1.41 m across, wider than the disc: free; behind: free.
        scan = jnp.array([2.0] + [10.0] * 7)
        free = np.asarray(corridor_free_m(scan, 10.0, 0.5, self.rays))
        assert free[0] == pytest.approx(1.5)
        assert np.all(np.isinf(free[1:]))
        # A 1.5 m disc is met at 45 deg too: a - sqrt(r^2 - b^2) = 1.414 - sqrt(2.25 - 2).
        free = np.asarray(corridor_free_m(scan, 10.0, 1.5, self.rays))
        assert free[1] == pytest.approx(math.sqrt(2.0) - 0.5, abs=1e-5)
        assert free[7] == pytest.approx(math.sqrt(2.0) - 0.5, abs=1e-5)
        # Between rays: at 30 deg, a = 2 cos 30 = 1.732, b = 1, met after 1.732 - sqrt(1.25).
        free = corridor_free_m(scan, 10.0, 1.5, jnp.radians(jnp.array([30.0])))
        assert float(free[0]) == pytest.approx(math.sqrt(3.0) - math.sqrt(1.25), abs=1e-5)

    def test_nothing_hit_is_free(self):
        assert np.all(np.isinf(corridor_free_m(jnp.full(8, 10.0), 10.0, 0.5, self.rays)))


class TestCollid:
    world = WorldCfg()

    def test_a_clear_way_is_the_catch_command(self):
        scan = jnp.array([1.0] + [10.0] * 7)  # an obstacle ahead, the catch goes left
        catch = jnp.array([0.3, 0.9, -1.5])
        np.testing.assert_allclose(collid_action(scan, catch, self.world, CollidCfg()), catch)

    def test_steps_around_a_blocked_way(self):
        # An obstacle 1 m ahead, the catch runs at it at 2 m/s. Corridor 0.36 + 0.15 =
        # 0.51 m: ahead is met after 0.49 m (< 1.5 m lookahead); 45 deg left passes 0.71 m
        # from the point: the nearest open direction (left before right). At 2 m/s that is
        # (1.41, 1.41), the lateral part clipped to the 1 m/s limit; the yaw rate is kept.
        scan = jnp.array([1.0] + [10.0] * 7)
        catch = jnp.array([2.0, 0.0, 0.5])
        a = collid_action(scan, catch, self.world, CollidCfg())
        np.testing.assert_allclose(a, [math.sqrt(2.0), 1.0, 0.5], atol=1e-6)

    def test_boxed_in_it_takes_the_longest_corridor(self):
        scan = jnp.array([1.0, 1.2, 1.4, 1.6, 1.8, 1.6, 1.4, 1.2])
        a = collid_action(scan, jnp.array([1.0, 0.0, 0.0]), self.world, CollidCfg())
        np.testing.assert_allclose(a[:2], [-1.0, 0.0], atol=1e-6)  # straight back


@struct.dataclass
class Forward:
    """A catch policy that always commands ``speed`` straight ahead (a jit pytree)."""

    speed: jax.Array
    is_pytree_policy: bool = struct.field(pytree_node=False, default=True)

    def init_carry(self, state, obs):
        return ()

    def step(self, carry, state, obs, key):
        return carry, jnp.stack([self.speed, 0.0, 0.0])


def _room(xy, yaw=0.0, target=(8.0, 8.0)):
    world = WorldCfg().for_scene("room_0")
    state = jax.jit(env.reset, static_argnums=1)(jax.random.key(0), world)
    return world, place(state, robot_xy=xy, robot_yaw=yaw, target_xy=target)


def _actions(catch, world, state):
    """(blended action, pi_catch's, pi_collid's) in ``state``."""
    obs = env.observe(state, world)
    key = jax.random.key(1)
    _, got = blended(catch, world).step((), state, obs, key)
    _, a_catch = as_recurrent(catch).step((), state, obs, key)
    a_collid = collid_action(collid_scan_m(state, world, CollidCfg()), a_catch, world, CollidCfg())
    return got, a_catch, a_collid


class TestWrapper:
    r = WorldCfg().base.radius_m

    def test_pure_catch_far_from_walls(self):
        world, state = _room((8.0, 6.0))
        catch = pursuit_policy(world)
        got, a_catch, _ = _actions(catch, world, state)
        np.testing.assert_array_equal(got, a_catch)

    def test_mostly_collid_at_contact(self):
        # Touching the left wall, facing it, the catch runs into it: pi_collid turns aside.
        world, state = _room((self.r, 8.0), yaw=math.pi)
        assert float(robot_clearance_m(state, world)) == pytest.approx(0.0, abs=1e-5)
        got, a_catch, a_collid = _actions(Forward(jnp.float32(2.0)), world, state)
        assert float(a_collid[0]) < 0.5  # no longer into the wall
        np.testing.assert_allclose(got, 0.1 * a_catch + 0.9 * a_collid, atol=1e-5)

    def test_hand_worked_in_between(self):
        # 0.55 m from the wall, facing it: w_c = 0.9 * (1 - 0.55) / 0.9 = 0.45.
        world, state = _room((self.r + 0.55, 8.0), yaw=math.pi)
        got, a_catch, a_collid = _actions(Forward(jnp.float32(2.0)), world, state)
        assert float(a_collid[0]) < 0.5
        np.testing.assert_allclose(got, 0.55 * a_catch + 0.45 * a_collid, atol=1e-5)

    def test_a_pytree_policy_stays_a_jit_argument(self):
        world = WorldCfg().for_scene("room_4")
        world = world.replace(episode=world.episode.replace(duration_s=0.5))
        policy = blended(Forward(jnp.float32(2.0)), world)
        assert policy.is_pytree_policy
        out = run_episodes(policy, jax.random.key(0), world, 4, contact_tol_m=1e-3)
        assert out["contacts"].shape == (4,)


def test_every_blend_constant_has_a_row_in_docs_scenes_md():
    import dataclasses
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()
    rows = [line for line in doc.splitlines() if line.startswith("|")]
    fields = [(f.name, getattr(BlendCfg(), f.name)) for f in dataclasses.fields(BlendCfg)]
    fields += [
        (f"collid.{f.name}", getattr(CollidCfg(), f.name)) for f in dataclasses.fields(CollidCfg)
    ]
    for name, default in fields:
        if name == "collid":
            continue
        mine = [r for r in rows if r.startswith(f"| `{name}` |")]
        assert mine, f"docs/scenes.md has no row for {name}"
        assert float(mine[0].split("|")[2]) == pytest.approx(float(default)), name


def test_plane_scan_shows_the_catch_policy_a_scan_at_its_cap():
    @struct.dataclass
    class ReadsScan:
        is_pytree_policy: bool = struct.field(pytree_node=False, default=True)

        def init_carry(self, state, obs):
            return ()

        def step(self, carry, state, obs, key):
            return carry, obs.scan_m[:3]

    world = WorldCfg().for_scene("room_0")
    _, state = _room((1.0, 8.0))
    obs = env.observe(state, world)
    assert float(obs.scan_m.min()) < 2.0  # the room's wall is in the scan
    policy = plane_scan(ReadsScan(), world)
    assert policy.is_pytree_policy
    _, seen = policy.step((), state, obs, jax.random.key(0))
    np.testing.assert_array_equal(seen, [10.0, 10.0, 10.0])


def test_deploy_shows_a_plane_trained_policy_the_planes_scan_only_where_it_matters():
    from dyncatch.policies.blend import Blended, PlaneScan, deploy
    from dyncatch.policies.registry import BASELINES

    plane, room = WorldCfg(), WorldCfg().with_scene("room_8")
    catch = BASELINES["pursuit"](room)
    assert isinstance(deploy(catch, plane, room), PlaneScan)  # trained on the plane, in a room
    assert deploy(catch, plane, plane) is catch  # the plane's scan already reads nothing
    assert deploy(catch, room, room) is catch  # trained with walls in its scan
    assert deploy(catch, None, room) is catch  # a baseline
    assert deploy(catch, plane, room, scan="own") is catch
    assert isinstance(deploy(catch, room, room, scan="plane"), PlaneScan)
    both = deploy(catch, plane, room, blend=True)
    assert isinstance(both, Blended) and isinstance(both.catch, PlaneScan)
    with pytest.raises(ValueError, match="scan must be"):
        deploy(catch, plane, room, scan="walls")
