"""Non-learned policies by name: ``factory(world) -> policy``. Learned methods add theirs."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dyncatch.policies.intercept import intercept_policy
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.config import WorldCfg

BASELINES: dict[str, Callable[[WorldCfg], Any]] = {
    "pursuit": pursuit_policy,
    "intercept": intercept_policy,
}
