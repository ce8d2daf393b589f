"""A small-budget run of Table II's experiment: the thresholds are measured, with margin."""

from __future__ import annotations

import jax
import pytest

from dyncatch.predictor.config import CollectCfg, PredictorCfg, TrainCfg
from dyncatch.predictor.data import collect
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.train import encode_samples, evaluate, fit
from dyncatch.sim.config import WorldCfg

BUDGET_STEPS = 200_000
TRAIN = TrainCfg(updates=1500)


def held_out_errors(behavior: str) -> dict[str, float]:
    world = WorldCfg().with_behavior(behavior)
    train, _ = collect(jax.random.key(0), world, CollectCfg(), BUDGET_STEPS)
    test, _ = collect(jax.random.key(1), world, CollectCfg(), BUDGET_STEPS // 2)
    errors = {}
    for kind in ("vanilla", "self_aware"):
        p = Predictor.for_world(PredictorCfg(kind=kind), world)
        enc = encode_samples(p, train)
        params, log = fit(p, TRAIN, enc, train.label_mps, len(train.label_mps), jax.random.key(2))
        assert log[-1][1] < log[0][1]  # the loss went down
        errors[kind] = evaluate(p, params, encode_samples(p, test), test.label_mps)
    return errors


@pytest.mark.slow
def test_self_aware_beats_vanilla_on_reactive_targets():
    err = held_out_errors("reactive")
    # Measured at this budget: vanilla 0.47 m/s, self-aware 0.21 m/s (targets run 0.8-1.8 m/s;
    # with the wall features of the old observation: 0.74 and 0.28).
    assert err["self_aware"] < 0.4
    assert err["vanilla"] > 2.0 * err["self_aware"]


@pytest.mark.slow
def test_both_kinds_learn_the_circle():
    err = held_out_errors("circle")
    # The label is ~1.3 m/s on average; measured here: vanilla 0.139, self-aware 0.152 m/s.
    # No input places the target in the world any more (the stored frame is centred on the
    # robot, the wall distances are gone), so from two sightings the circle's turn direction
    # is unknown: repeating the last displacement errs by 0.173 m/s on these samples (it was
    # 0.002 and 0.048 with wall distances in the inputs).
    assert err["vanilla"] < 0.16
    assert err["self_aware"] < 0.18
