"""The ``league`` behaviour: a member at weight 1 plays exactly that behaviour, the draw
follows the weights (a binomial test), nested members' points ride with the frame, and bad
members or weights are refused naming the field."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.cli.main import main
from dyncatch.sim import env
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT, save_evader
from dyncatch.sim.behaviors.league import league_weights
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import ConfigError, validate_world

from .helpers import away_net, fixed_rollout

BASE = WorldCfg().with_speed(1.6)


def _league(world: WorldCfg = BASE, **fields) -> WorldCfg:
    w = world.with_behavior("league")
    return w.replace(target=w.target.replace(**fields))


@pytest.fixture(scope="module")
def evader_file(tmp_path_factory):
    """A hand-made evader: turn = clip(-robot_rel_left_m, -1, 1) x pi (away from the robot)."""
    return str(save_evader(tmp_path_factory.mktemp("ev") / EVADER_CHECKPOINT, away_net()))


def _episode(world: WorldCfg, key, steps: int = 60):
    """Target positions (scene frame) over ``steps`` steps under a fixed command."""
    s0 = env.reset(key, world)
    states, _, _ = fixed_rollout(s0, jnp.array([0.8, 0.0, 0.3]), world, steps)
    return states.target.xy_m + states.origin_xy_m


class TestOneMemberAtWeightOne:
    """All the weight on one member: the very episodes of that behaviour alone."""

    @pytest.mark.parametrize("name", ["reactive", "random_reactive", "circle"])
    def test_scripted(self, name):
        league = _league(
            league_behaviors=("reactive", "random_reactive", "circle"),
            league_weights=tuple(
                float(n == name) for n in ("reactive", "random_reactive", "circle")
            ),
        )
        validate_world(league)
        # Each episode compiled once for both seeds (a key is data, not part of the program).
        run_league = jax.jit(lambda k: _episode(league, k))
        run_alone = jax.jit(lambda k: _episode(BASE.with_behavior(name), k))
        for seed in (0, 1):
            key = jax.random.key(seed)
            np.testing.assert_array_equal(run_league(key), run_alone(key))

    def test_evader(self, evader_file):
        league = _league(
            league_behaviors=("reactive",),
            league_evaders=(evader_file,),
            league_weights=(0.0, 1.0),
        )
        learned = BASE.with_behavior("learned")
        learned = learned.replace(target=learned.target.replace(evader_checkpoint=evader_file))
        validate_world(league)
        validate_world(learned)
        key = jax.random.key(4)
        got = jax.jit(lambda k: _episode(league, k))(key)
        want = jax.jit(lambda k: _episode(learned, k))(key)
        np.testing.assert_array_equal(got, want)


class TestWeights:
    def test_the_share_rule_by_hand(self, evader_file):
        w = _league(
            league_behaviors=("reactive", "circle"),
            league_evaders=(evader_file, evader_file, evader_file),
            league_scripted_share=0.4,
        )
        # 0.4 split over 2 scripted members, 0.6 over 3 evaders.
        np.testing.assert_allclose(league_weights(w), [0.2, 0.2, 0.2, 0.2, 0.2])
        w = w.replace(target=w.target.replace(league_scripted_share=0.8))
        np.testing.assert_allclose(league_weights(w), [0.4, 0.4, 0.2 / 3, 0.2 / 3, 0.2 / 3])
        # One kind only: uniform over it, the share ignored.
        only = _league(league_behaviors=("reactive", "circle"), league_scripted_share=0.1)
        np.testing.assert_allclose(league_weights(only), [0.5, 0.5])
        # Explicit weights are normalised.
        ex = w.replace(target=w.target.replace(league_weights=(2.0, 0.0, 1.0, 1.0, 0.0)))
        np.testing.assert_allclose(league_weights(ex), [0.5, 0.0, 0.25, 0.25, 0.0])

    def test_each_member_is_drawn_at_its_weight(self, evader_file):
        # 20 000 resets; a member's count is binomial, so its frequency lies within 4.5
        # standard errors of its weight with probability > 1 - 1e-5 (each member). A wrong
        # rule (uniform thirds) would miss the 0.5 member by 0.17, about 47 standard errors.
        w = _league(
            league_behaviors=("reactive", "random_reactive"),
            league_evaders=(evader_file,),
            league_weights=(0.5, 0.3, 0.2),
        )
        validate_world(w)
        n = 20_000
        keys = jax.random.split(jax.random.key(11), n)
        member = np.asarray(
            jax.jit(jax.vmap(lambda k: env.reset(k, w)))(keys).target.behavior_state.member
        )
        freq = np.bincount(member, minlength=3) / n
        p = np.array([0.5, 0.3, 0.2])
        tolerance = 4.5 * np.sqrt(p * (1 - p) / n)
        assert np.all(np.abs(freq - p) <= tolerance), (freq, p, tolerance)

    def test_a_zero_weight_never_plays(self):
        w = _league(league_behaviors=("reactive", "circle"), league_weights=(0.0, 1.0))
        keys = jax.random.split(jax.random.key(3), 2000)
        member = np.asarray(jax.vmap(lambda k: env.reset(k, w))(keys).target.behavior_state.member)
        assert np.all(member == 1)


def test_a_nested_evaders_corner_rides_with_the_frame(evader_file):
    w = _league(
        BASE.with_scene("arena"),
        league_behaviors=("reactive",),
        league_evaders=(evader_file,),
        league_weights=(0.0, 1.0),
    )
    s0 = env.reset(jax.random.key(1), w)
    states, _, _ = jax.jit(lambda s: fixed_rollout(s, jnp.array([1.0, 0.0, 0.5]), w, 30))(s0)
    corner = states.target.behavior_state.states[1].corner_xy_m
    np.testing.assert_allclose(corner, -states.origin_xy_m, atol=1e-5)
    assert float(jnp.abs(states.origin_xy_m).max()) > 0.1  # the frame did move


class TestRefused:
    def _refused(self, world, field, *words):
        with pytest.raises(ConfigError) as err:
            validate_world(world)
        msg = str(err.value)
        assert field in msg
        for w in words:
            assert w in msg

    def test_a_reflecting_or_unscripted_member(self):
        self._refused(_league(league_behaviors=("bounce",)), "league_behaviors", "bounce")
        self._refused(_league(league_behaviors=("learned",)), "league_behaviors", "league-evaders")

    def test_an_empty_league(self):
        self._refused(_league(league_behaviors=()), "league_behaviors", "empty")

    def test_weights_of_the_wrong_count_or_sign(self):
        self._refused(_league(league_weights=(1.0, 1.0)), "league_weights", "give 1")
        self._refused(_league(league_weights=(-1.0,)), "league_weights", "non-negative")
        self._refused(_league(league_scripted_share=1.5), "league_scripted_share", "[0, 1]")

    def test_a_missing_evader(self, tmp_path):
        self._refused(
            _league(league_evaders=(str(tmp_path / "none"),)),
            "league_evaders",
            "--world.target.league-evaders",
            "no such file",
        )


def test_the_eval_command_plays_a_league(evader_file, capsys):
    rc = main(
        [
            "eval",
            "pursuit",
            "--speeds",
            "1.6",
            "--episodes",
            "4",
            "--behavior",
            "league",
            "--world.target.league-behaviors",
            "reactive",
            "circle",
            "--world.target.league-evaders",
            evader_file,
        ]
    )
    assert rc == 0, capsys.readouterr().err
