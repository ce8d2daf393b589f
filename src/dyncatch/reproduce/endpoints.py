"""The primary endpoints a reproduction declares before it runs (issue 31).

A primary endpoint is judged on its own, unadjusted, and reported with the smallest
difference the run could resolve and the seeds 80 % power would need at ``margin``. Every
other ordering or headroom check is secondary: one family, Holm-corrected
(``aggregate.judge_family``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from tyro.constructors import PrimitiveConstructorSpec

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

    @property
    def spec(self) -> str:
        """The command-line form ``parse_endpoint`` reads: ``WINNER-LOSER:BEHAVIOR:SPEED``
        (an ordering) or ``headroom:BEHAVIOR:SPEED``, then ``:MARGIN`` if not 0.10."""
        head = "headroom" if self.claim is None else f"{self.claim[0]}-{self.claim[1]}"
        tail = "" if self.margin == Endpoint.margin else f":{self.margin:g}"
        return f"{head}:{self.behavior}:{self.speed_mps:g}{tail}"

    @classmethod
    def from_json(cls, d: dict) -> Endpoint:
        """An endpoint from its ``plan.json`` record (``dataclasses.asdict``)."""
        claim = d.get("claim")
        return cls(**{**d, "claim": None if claim is None else tuple(claim)})


def parse_endpoint(text: str) -> Endpoint:
    """``sp_rl-rl:reactive:1.8`` (success of sp_rl minus rl's on reactive at 1.8 m/s) or
    ``headroom:reactive:1.8`` (the oracle against the best non-oracle method), optionally
    ``:MARGIN``. Names are checked against the registries by ``validate_plan``."""
    parts = text.split(":")
    try:
        if len(parts) not in (3, 4):
            raise ValueError
        head, behavior, speed = parts[:3]
        margin = float(parts[3]) if len(parts) == 4 else Endpoint.margin
        speed_mps = float(speed)
    except ValueError:
        raise ValueError(
            f"--primary-endpoints {text!r}: write WINNER-LOSER:BEHAVIOR:SPEED or "
            "headroom:BEHAVIOR:SPEED (optionally :MARGIN), e.g. sp_rl-rl:reactive:1.8"
        ) from None
    at = "" if abs(speed_mps - TOP_SPEED_MPS) < 1e-9 else f"_{speed_mps:g}mps"
    if head == "headroom":
        name = f"oracle_headroom_{behavior}{at}"
        return Endpoint(name, "headroom", behavior, speed_mps, margin=margin)
    winner, _, loser = head.partition("-")
    return Endpoint(
        f"{winner}_vs_{loser}_{behavior}{at}",
        "ordering",
        behavior,
        speed_mps,
        (winner, loser),
        margin=margin,
    )


EndpointArg = Annotated[
    Endpoint,
    PrimitiveConstructorSpec(
        nargs=1,
        metavar="ENDPOINT",
        instance_from_str=lambda args: parse_endpoint(args[0]),
        is_instance=lambda x: isinstance(x, Endpoint),
        str_from_instance=lambda e: [e.spec],
    ),
]
"""An ``Endpoint`` on the command line, in ``Endpoint.spec``'s form."""


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


def validate_endpoints(endpoints, behaviors, methods) -> None:
    """Raise ValueError (one line, naming ``--primary-endpoints``) for an endpoint whose
    behaviour or methods are not registered (``behaviors``, ``methods``: the registries' keys),
    or whose speed or margin cannot work."""
    for e in endpoints:
        where = f"--primary-endpoints {e.spec}"
        if e.behavior not in behaviors:
            raise ValueError(
                f"{where}: unknown behaviour {e.behavior!r}; choose from {', '.join(behaviors)}"
            )
        for m in e.claim or ():
            if m not in methods:
                raise ValueError(f"{where}: unknown method {m!r}; choose from {', '.join(methods)}")
        if e.claim is not None and e.claim[0] == e.claim[1]:
            raise ValueError(f"{where}: compares {e.claim[0]!r} with itself")
        if e.speed_mps < 0 or e.margin <= 0:
            raise ValueError(f"{where}: the speed must be >= 0 and the margin > 0")


Resolution = Literal["resolved", "equivalent within the margin", "unresolved"]
"""How a check came out (``aggregate``: a primary endpoint on its own p-value and margin, a
secondary one on its Holm-adjusted p-value)."""


def against_paper(
    ci95: tuple[float, float], paper: float | None, resolution: Resolution, margin: float
) -> str | None:
    """An endpoint's verdict on the paper's claim, from how the check came out
    (``resolution``, judged where the check is: ``aggregate``), our 95 % CI of the
    difference and the paper's value (None where the paper gives no number: None).

    - ``reproduced``: resolved on the paper's side, the CI holding the paper's value;
    - ``direction reproduced, smaller`` (or ``larger``): resolved on the paper's side, the
      CI not holding its value;
    - ``contradicted``: resolved on the other side (or the paper's value is 0), or
      equivalent within +-margin while the paper's value is not;
    - ``unresolved, paper's value excluded``: unresolved, the CI not holding the paper's
      value; ``unresolved``: it holds it.
    """
    if paper is None:
        return None
    lo, hi = ci95
    holds_paper = lo <= paper <= hi
    if resolution == "resolved":
        ours = 1.0 if lo + hi > 0 else -1.0
        if ours * paper <= 0:
            return "contradicted"
        if holds_paper:
            return "reproduced"
        smaller = abs(paper) > max(abs(lo), abs(hi))
        return "direction reproduced, " + ("smaller" if smaller else "larger")
    if resolution == "equivalent within the margin":
        return "reproduced" if abs(paper) < margin else "contradicted"
    return "unresolved" if holds_paper else "unresolved, paper's value excluded"
