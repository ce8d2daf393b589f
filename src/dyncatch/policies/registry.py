"""Non-learned policies (baselines) by name, each self-describing like a learned ``Method``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from dyncatch.policies.intercept import intercept_policy
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.config import WorldCfg


@dataclass(frozen=True)
class Baseline:
    name: str
    label: str
    """Name in tables and legends."""
    color: str
    """Matplotlib colour in every figure."""
    doc: str
    factory: Callable[[WorldCfg], Any]
    """``factory(world) -> policy`` (see ``dyncatch.policies.api``)."""

    def __call__(self, world: WorldCfg):
        return self.factory(world)


BASELINES: dict[str, Baseline] = {
    b.name: b
    for b in (
        Baseline(
            "pursuit",
            "pursuit (scripted)",
            "C7",
            "runs at the last sighting, spins to search",
            pursuit_policy,
        ),
        Baseline(
            "intercept",
            "intercept (KF)",
            "C8",
            "constant-velocity Kalman filter on the sightings + interception point",
            intercept_policy,
        ),
    )
}
