"""The behaviour predictor of Section III-B: learn the target's next velocity from 2 Hz frames.

``features`` turns a sensor history into network inputs (``vanilla`` or ``self_aware``),
``data`` collects labelled samples from robot-target interaction, ``model`` holds the MLP and
``predict``, ``train`` fits it with the L2 loss of eq. 4, ``checkpoint`` saves and loads it,
``table`` reproduces Table II.
"""

from dyncatch.predictor.config import CollectCfg, PredictorCfg, TrainCfg
from dyncatch.predictor.features import FEATURES, History, history_from_state
from dyncatch.predictor.model import Predictor, predict

__all__ = [
    "FEATURES",
    "CollectCfg",
    "History",
    "Predictor",
    "PredictorCfg",
    "TrainCfg",
    "history_from_state",
    "predict",
]
