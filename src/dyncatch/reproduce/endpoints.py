"""The primary endpoints a reproduction declares before it runs (issue 31).

A primary endpoint is judged on its own, unadjusted, and reported with the smallest
difference the run could resolve and the seeds 80 % power would need at ``margin``. Every
other ordering or headroom check is secondary: one family, Holm-corrected
(``aggregate.judge_family``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

CheckKind = Literal["ordering", "headroom"]


@dataclass(frozen=True)
class Endpoint:
    """One pre-declared comparison of success at one speed on one behaviour."""

    name: str
    kind: CheckKind
    """``ordering``: ``claim``'s winner against its loser (``aggregate.ordering_checks``);
    ``headroom``: the oracle against the best non-oracle method (``headroom_checks``)."""
    behavior: str
    speed_mps: float
    claim: tuple[str, str] | None = None
    """(winner, loser) method names of an ordering; None for a headroom."""
    metric: str = "success_rate"
    margin: float = 0.10
    """The difference worth resolving (issue 31's target CI half-width): the power line
    gives the seeds per method for 80 % power at it, and an interval inside +-margin reads
    as equivalence at that margin."""

    def matches(self, check: dict) -> bool:
        """Whether an aggregate check dict is this endpoint's."""
        speed = check.get("speed_mps")
        return (
            check.get("kind") == self.kind
            and check.get("behavior") == self.behavior
            and check.get("metric", "success_rate") == self.metric
            and speed is not None
            and abs(speed - self.speed_mps) < 1e-9
            and (self.claim is None or check.get("claim") == f"{self.claim[0]} > {self.claim[1]}")
        )


TOP_SPEED_MPS = 1.8
"""The paper's high speed (80 % of the robot's), where its claims are made."""

PRIMARY_ENDPOINTS: tuple[Endpoint, ...] = (
    Endpoint("sp_rl_vs_rl_reactive", "ordering", "reactive", TOP_SPEED_MPS, ("sp_rl", "rl")),
    Endpoint(
        "sp_rl_vs_rl_random_reactive",
        "ordering",
        "random_reactive",
        TOP_SPEED_MPS,
        ("sp_rl", "rl"),
    ),
    Endpoint("oracle_headroom_reactive", "headroom", "reactive", TOP_SPEED_MPS),
    Endpoint("oracle_headroom_random_reactive", "headroom", "random_reactive", TOP_SPEED_MPS),
)
"""``sp_rl - rl`` success at 1.8 m/s on reactive and random_reactive, and the oracle's
headroom there: the reproduction's verdicts; everything else is secondary."""
