"""How a reproduction shows and judges each method of ``dyncatch.rl.methods.METHODS``: its
name in tables and legends, its colour, the paper's claims about it, whether it is filmed
and whether a default reproduction runs it.

``Method`` keeps what training and evaluation need (its input, its policy source); these
are the paper's presentation facts, beside its numbers (``paper.py``). A method added to
``METHODS`` gets an entry here; a registry without one for every method fails on import.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from dyncatch.rl.methods import METHODS


@dataclass(frozen=True)
class Presentation:
    """A method as the reproduction shows it (``name`` is its key in ``METHODS``)."""

    name: str
    label: str
    """Name in tables and legends (the paper's where it has one)."""
    color: str
    """Matplotlib colour in every figure."""
    beats: tuple[str, ...] = ()
    """The paper's high-speed claims: this method catches more, and sooner, than these."""
    filmed: bool = False
    """The reproduction records one video per behaviour of this method's policy."""
    reproduced: bool = True
    """Part of a reproduction unless ``dyncatch reproduce --methods`` names it (the
    methods beyond the paper are opt-in, so the default runs stay as long as they were)."""


PRESENTATION: dict[str, Presentation] = {
    p.name: p
    for p in (
        Presentation("rl", "RL", "C0"),
        Presentation("p_rl", "P+RL", "C1"),
        Presentation("sp_fp", "SP+FP", "C2", beats=("rl",)),
        Presentation("sp_rl", "SP+RL (ours)", "C3", beats=("rl", "p_rl", "sp_fp"), filmed=True),
        Presentation("gt_rl", "GT-Pred RL", "C4"),
        Presentation("st_fp", "ST+FP", "C5", reproduced=False),
        Presentation("st_rl", "ST+RL", "C6", beats=("sp_rl",), reproduced=False),
        Presentation("rnn_rl", "RNN+RL", "C7", reproduced=False),
        Presentation("rnn_sp_rl", "RNN+SP+RL", "C8", reproduced=False),
    )
}
"""Every method's presentation, in ``METHODS``'s order (the order of tables and legends)."""

if list(PRESENTATION) != list(METHODS):
    raise ImportError(
        "dyncatch.reproduce.presentation.PRESENTATION must list the methods of "
        f"dyncatch.rl.methods.METHODS in its order: {list(METHODS)} (has {list(PRESENTATION)})"
    )


def method_labels() -> dict[str, str]:
    """Each method's label by name (for plots of layers below this one)."""
    return {name: p.label for name, p in PRESENTATION.items()}


def reproduced_methods() -> tuple[str, ...]:
    """The methods a reproduction compares by default (``Presentation.reproduced``), in
    registry order."""
    return tuple(name for name, p in PRESENTATION.items() if p.reproduced)


def chosen(names: Iterable[str] | None = None) -> tuple[str, ...]:
    """The methods named in ``names`` (default ``reproduced_methods()``), in registry order."""
    wanted = set(reproduced_methods() if names is None else names)
    return tuple(name for name in METHODS if name in wanted)


def paper_claims(names: Iterable[str] | None = None) -> tuple[tuple[str, str], ...]:
    """The high-speed ordering claims as (winner, loser) pairs among ``names`` (default: a
    default reproduction's methods): the paper's, and ``st_rl > sp_rl`` of the tracker."""
    among = chosen(names)
    return tuple(
        (name, other) for name in among for other in PRESENTATION[name].beats if other in among
    )


def filmed_methods(names: Iterable[str]) -> tuple[str, ...]:
    """The methods among ``names`` whose policies are filmed, in registry order."""
    return tuple(name for name in chosen(names) if PRESENTATION[name].filmed)
