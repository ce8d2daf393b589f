"""The paper's published numbers, for side-by-side tables (different simulator: Isaac Gym).

Every number of the paper the reproduction shows lives here: Table I, Table II and what
the text gives of Fig. 9, with the paper's speeds, budgets and Fig. 9 scenes. The layers
below (``predictor.table``) take them as arguments.
"""

from __future__ import annotations

PAPER_SPEEDS_MPS = (0.8, 1.0, 1.2, 1.4, 1.6, 1.8)

PAPER_TABLE_I: dict[tuple[str, str], tuple[tuple[float, float], ...]] = {
    # (behavior, method): ((success, catch time s) per speed 0.8 ... 1.8, then the average)
    ("reactive", "rl"): (
        (0.952, 3.24),
        (0.716, 8.46),
        (0.522, 11.50),
        (0.236, 16.30),
        (0.026, 19.56),
        (0.0, 20.00),
        (0.409, 13.18),
    ),
    ("reactive", "p_rl"): (
        (0.871, 4.62),
        (0.803, 5.88),
        (0.493, 11.40),
        (0.200, 16.70),
        (0.005, 19.10),
        (0.009, 20.00),
        (0.397, 12.95),
    ),
    ("reactive", "sp_fp"): (
        (0.969, 3.02),
        (0.943, 3.40),
        (0.891, 5.22),
        (0.625, 10.32),
        (0.463, 12.88),
        (0.275, 15.90),
        (0.694, 8.46),
    ),
    ("reactive", "sp_rl"): (
        (0.982, 2.48),
        (0.978, 2.62),
        (0.978, 2.82),
        (0.987, 2.94),
        (0.973, 3.70),
        (0.908, 5.76),
        (0.968, 3.39),
    ),
    ("random_reactive", "rl"): (
        (0.769, 6.67),
        (0.622, 9.73),
        (0.489, 12.49),
        (0.245, 16.36),
        (0.105, 18.33),
        (0.022, 19.70),
        (0.375, 13.88),
    ),
    ("random_reactive", "p_rl"): (
        (0.791, 5.82),
        (0.655, 8.39),
        (0.345, 13.93),
        (0.148, 17.47),
        (0.096, 18.36),
        (0.061, 19.01),
        (0.349, 13.83),
    ),
    ("random_reactive", "sp_fp"): (
        (0.996, 2.13),
        (0.998, 2.42),
        (0.991, 3.04),
        (0.925, 4.84),
        (0.725, 8.97),
        (0.502, 13.44),
        (0.856, 5.81),
    ),
    ("random_reactive", "sp_rl"): (
        (0.987, 2.38),
        (0.978, 2.86),
        (0.978, 3.10),
        (0.961, 4.13),
        (0.925, 5.48),
        (0.864, 7.34),
        (0.949, 4.22),
    ),
}
"""Table I of the paper (success rate / catching time, 20 s limit); no gt_rl, pursuit or
intercept rows were published."""


def paper_cell(behavior: str, method: str, speed_mps: float | None) -> tuple[float, float] | None:
    """(success, time) at a speed, or the average column when ``speed_mps`` is None."""
    row = PAPER_TABLE_I.get((behavior, method))
    if row is None:
        return None
    if speed_mps is None:
        return row[-1]
    for i, v in enumerate(PAPER_SPEEDS_MPS):
        if abs(v - speed_mps) < 1e-6:
            return row[i]
    return None


def paper_difference(
    behavior: str, winner: str, loser: str, speed_mps: float | None, metric: str = "success_rate"
) -> float | None:
    """The paper's ``winner``-over-``loser`` difference in Table I, as a check measures it:
    success of the winner minus the loser's, or seconds the winner catches sooner; None
    where the paper gives either method no number there."""
    a, b = paper_cell(behavior, winner, speed_mps), paper_cell(behavior, loser, speed_mps)
    if a is None or b is None:
        return None
    return a[0] - b[0] if metric == "success_rate" else b[1] - a[1]


PAPER_TABLE_II: dict[tuple[str, str], tuple[float, ...]] = {
    ("circle", "vanilla"): (0.001, 0.0, 0.0, 0.0),
    ("circle", "self_aware"): (0.002, 0.001, 0.001, 0.0),
    ("bounce", "vanilla"): (0.048, 0.022, 0.024, 0.022),
    ("bounce", "self_aware"): (0.027, 0.039, 0.026, 0.022),
    ("reactive", "vanilla"): (1.251, 1.201, 1.261, 1.197),
    ("reactive", "self_aware"): (0.398, 0.211, 0.205, 0.128),
}
"""Table II of the paper: errors ||v_hat - v||_2 (m/s) at ``PAPER_BUDGETS``; it reports no
random_reactive row."""
PAPER_BUDGETS = (200_000, 500_000, 1_000_000, 2_000_000)
"""Table II's interaction budgets (simulator steps)."""
PAPER_TABLE_II_ERRORS: dict[tuple[str, str, int], float] = {
    (behavior, kind, budget): error
    for (behavior, kind), row in PAPER_TABLE_II.items()
    for budget, error in zip(PAPER_BUDGETS, row, strict=True)
}
"""``PAPER_TABLE_II`` by (behaviour, kind, budget): what ``predictor.table.run_table`` takes."""


PAPER_FIG9_SCENES = ("room_0", "room_4", "room_8", "woods_plane", "woods_rough", "woods_stairs")
"""Our scenes for Fig. 9's Room-0/4/8 and Wood-P/R/S (``dyncatch.sim.scenes``)."""
PAPER_FIG9_SUCCESS: dict[tuple[str, str], float] = {
    ("room_0", "circle"): 0.999,
    ("room_0", "bounce"): 0.865,
    ("room_0", "reactive"): 0.738,
}
"""Fig. 9's success rates that the paper's text gives (Sec. V-E: "In indoor environments
devoid of obstacles (Room-0), the Circle movement exhibits the highest success rate at
99.9%, followed by Bounce and Reactive movements at 86.5% and 73.8%"), for its method
deployed with its collision-avoidance blend. The bars of the other cells are only drawn in
the figure; no catch time is given."""
PAPER_FIG9_SCENE_AVERAGE: dict[str, float] = {"room_0": 0.868}
"""Fig. 9's average success over the behaviours of a scene, where the text gives it ("The
average success rate for this environment is 86.8%")."""
PAPER_FIG9_METHOD = "sp_rl+blend"
"""The Fig. 9 row the paper's values belong to (its method with eq. 10's blend)."""
