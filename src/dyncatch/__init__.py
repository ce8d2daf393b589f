"""dyncatch."""

from dyncatch.gym.registration import register_envs

register_envs()
