"""A checkpoint header's PPO config: a header from before ``obs_min_std`` keeps no floor."""

from __future__ import annotations

from pathlib import Path

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.policy import header_ppo
from dyncatch.utils.config_io import to_json


def _ppo_dict(ppo: PPOCfg) -> dict:
    return to_json(ppo)


def test_a_header_without_the_floor_is_read_with_none():
    recorded = _ppo_dict(PPOCfg())
    del recorded["obs_min_std"]
    ppo = header_ppo(Path("old/checkpoint.safetensors"), {"ppo": recorded})
    assert ppo.obs_min_std == 0.0


def test_a_header_with_the_floor_keeps_it():
    recorded = _ppo_dict(PPOCfg().replace(obs_min_std=0.25))
    ppo = header_ppo(Path("new/checkpoint.safetensors"), {"ppo": recorded})
    assert ppo.obs_min_std == 0.25
    assert PPOCfg().obs_min_std == 0.0
