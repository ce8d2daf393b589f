"""The stance-force controllers of the trot, by name (``GaitCfg.controller``).

Each is ``f(obs, cmd, state, stance, cfg) -> (4, 3)`` ground reaction forces on the stance
feet (zeros elsewhere), which ``gait.trot_step`` turns into joint torques ``-J^T f``.
"""

from __future__ import annotations

from dyncatch.fullbody.gait import stance_forces
from dyncatch.fullbody.mpc import mpc_stance_forces

STANCE_CONTROLLERS = {"trot_dls": stance_forces, "mpc": mpc_stance_forces}
