"""World configuration: every model constant of the catch world, with units.

Each ``*Cfg`` is a frozen dataclass and a JAX pytree at once: numeric fields are leaves (so a
jitted step takes them as arguments and can be ``vmap``-ed over them), fields marked
``static`` shape the computation and are compile-time constants. The defaults and their
sources are listed in ``docs/model.md``. ``TargetCfg`` is composed in
``dyncatch.sim.behaviors`` from the target body's fields and each behaviour's own config class.
"""

from __future__ import annotations

import math
from typing import Literal

from flax import struct

from dyncatch.sim.behaviors import TargetCfg
from dyncatch.sim.fields import static
from dyncatch.sim.scene_cfg import ROUGH, STAIRS, AvoidCfg, RoomCfg, TerrainCfg, WoodsCfg
from dyncatch.sim.scenes import SceneName, get_scene


@struct.dataclass
class ArenaCfg:
    size_m: float = 16.0
    """Side of the square region (walls in the ``arena`` scene, the bounce target's virtual
    boundary on the ``open_plane``); its lower-left corner is the world origin."""


@struct.dataclass
class SceneCfg:
    """Which scene (``dyncatch.sim.scenes.SCENES``) and the range scan s_env (eq. 3)."""

    name: SceneName = static("open_plane")
    """Scene, a key of ``dyncatch.sim.scenes.SCENES``: ``open_plane`` (the paper's Table I
    setting, the default since issue 12), ``arena`` (walled 16 m square, the first slice's
    world), ``room_0``/``room_4``/``room_8`` or ``woods_plane``/``woods_rough``/
    ``woods_stairs`` (docs/scenes.md); ``--scene`` on every command."""
    scan_rays: int = static(8)
    """Rays of the range scan s_env, evenly spread around the base heading (first: ahead)."""
    scan_range_m: float = 10.0
    """Farthest distance a ray reports; it reads this when it hits nothing."""


@struct.dataclass
class BaseCfg:
    """Reduced-order quadruped base under a velocity-tracking gait controller (Aliengo-like)."""

    max_forward_mps: float = 2.0
    """Largest forward command."""
    max_backward_mps: float = 1.0
    """Largest backward command (magnitude)."""
    max_lateral_mps: float = 1.0
    """Largest sideways command (magnitude)."""
    max_yaw_rate_rps: float = 2.0
    """Largest yaw-rate command (magnitude)."""
    max_speed_mps: float = static(math.inf)
    """Largest ground speed commanded, the norm of (vx, vy): a command outside it is scaled
    back along its direction after the per-axis limits; inf (the default) leaves the box of
    those limits alone, compiling no scaling at all (a compile-time constant). The named
    reading ``trot_envelope`` sets the full-body trot's."""
    lag_s: float = 0.1
    """Time constant of the first-order tracking of commanded velocities."""
    max_lin_accel_mps2: float = 4.0
    """Largest linear acceleration of the base, per axis."""
    max_yaw_accel_rps2: float = 10.0
    """Largest yaw acceleration of the base."""
    max_lateral_accel_mps2: float = math.inf
    """Turning at speed: the yaw rate is held to this over the base's speed (the velocity
    vector's centripetal acceleration |v| x |yaw rate|); inf (the default) is no limit."""
    gait_noise_mps: float = 0.05
    """Std of the gait-induced linear velocity noise, per control step."""
    gait_noise_yaw_rps: float = 0.05
    """Std of the gait-induced yaw-rate noise, per control step."""
    length_m: float = 0.65
    """Footprint length (Aliengo trunk and legs)."""
    width_m: float = 0.30
    """Footprint width."""
    height_m: float = 0.40
    """Height of the trunk top, where the arm is mounted."""

    @property
    def radius_m(self) -> float:
        """Radius of the circle around the footprint, used against walls."""
        return 0.5 * (self.length_m**2 + self.width_m**2) ** 0.5


ArmAim = Literal["true", "sighting"]


@struct.dataclass
class ArmCfg:
    """A 6-DOF arm with Z1-like geometry, driven by damped-least-squares IK.

    Joints: yaw, pitch, pitch, pitch, yaw, roll. Lengths follow the Unitree Z1 datasheet
    rounded to the centimetre.
    """

    mount_x_m: float = 0.15
    """Mount point ahead of the base centre."""
    shoulder_height_m: float = 0.10
    """Joint 2 above the mount (joint-1 column)."""
    upper_arm_m: float = 0.35
    """Joint 2 to joint 3."""
    forearm_m: float = 0.22
    """Joint 3 to joint 4."""
    wrist_m: float = 0.07
    """Joint 4 to joint 5."""
    wrist2_m: float = 0.05
    """Joint 5 to joint 6."""
    gripper_m: float = 0.13
    """Joint 6 to the gripper point."""
    joint_min_rad: tuple[float, ...] = (-2.6, -0.3, -2.9, -1.4, -1.5, -2.8)
    """Lower joint limits."""
    joint_max_rad: tuple[float, ...] = (2.6, 2.9, 0.3, 1.4, 1.5, 2.8)
    """Upper joint limits."""
    max_joint_vel_rps: float = 3.14
    """Joint-velocity limit (Z1: 180 deg/s)."""
    stow_rad: tuple[float, ...] = (0.0, 0.6, -2.2, 1.0, 0.0, 0.0)
    """Folded pose held while the target is far."""
    activation_distance_m: float = 1.0
    """The arm reaches once the target is this close to the base centre (d_arm,act)."""
    ik_damping: float = 0.05
    """Damping lambda of the DLS solve (metres)."""
    ik_gain: float = 1.0
    """Fraction of the gripper error corrected per IK step (before velocity limits)."""
    catch_offset_m: float = 0.10
    """The catch point sits this far below the gripper."""
    catch_radius_m: float = 0.05
    """Success: target centre within this distance of the catch point (d_suc)."""
    aim: ArmAim = static("true")
    """What the arm reaches for (x_goal,ee of IV-A): ``true``, the target itself at every
    200 Hz sub-step (the default, "x_goal,ee = x_obj"); ``sighting`` (reading
    ``arm_on_sighting``), the last delivered camera sighting, once one exists, and the
    activation distance is measured to it (the JAX world only)."""


@struct.dataclass
class SensorCfg:
    """The onboard camera: sample-and-hold target positions at a low rate, in a cone."""

    rate_hz: float = 2.0
    """Visual observation rate f_vis."""
    fov_rad: float = math.radians(120.0)
    """Full horizontal field of view around the base heading (theta_FoV)."""
    range_m: float = 10.0
    """Farthest distance at which the target is detected."""
    latency_s: float = 0.0
    """Delay between capture and availability; must be shorter than one camera period."""
    noise_m: float = 0.0
    """Std of the position noise added to each observation."""

    @property
    def period_s(self) -> float:
        """Time between camera frames, 1 / f_vis."""
        return 1.0 / self.rate_hz


@struct.dataclass
class ObservationCfg:
    """What of the sensor's state the policy's observation (``sim.state.Obs``) carries."""

    staleness_inputs: bool = static(False)
    """Whether ``Obs.flat`` (every method's policy input) carries ``time_since_seen_s`` and
    ``visible``, the age of the held sighting and whether the last frame saw the target.
    False (the default) is the paper's state s = [s_rob, s_obj, v_hat_obj, s_env] with
    s_obj = [p_obj] (IV-A): no age of the sighting, no seen flag. True, the earlier default
    (issue 32), is the reading ``staleness_observation``; a checkpoint or plan.json recorded
    before this field existed fed them and is read as True (``LEGACY_WORLD``). Scripted
    policies read them from ``Obs`` either way."""


LEGACY_WORLD: dict[str, object] = {"observation.staleness_inputs": True}
"""World fields (dotted, under ``WorldCfg``) whose default is not what the code did before
they were recorded, mapped to what it did: a record of a world (a checkpoint header, a
plan.json) that lacks one is read with this value, never with today's default. Every
observation carried the staleness inputs before ``observation.staleness_inputs`` existed."""


VisibilityReading = Literal["per_second", "per_step"]
SuccessReading = Literal["terminal", "every_step"]


@struct.dataclass
class RewardCfg:
    """Weights of eq. 9, and how w2 is read (the paper does not say per what it is paid)."""

    pursuit: float = 1.0
    """w1, on the change of robot-target distance (eq. 6)."""
    visibility: float = 0.2
    """w2, on the target being inside the field of view (eq. 7); paper: 0.2."""
    success: float = 5.0
    """w3, on the catch (eq. 8)."""
    visibility_per: VisibilityReading = static("per_second")
    """Reading of w2: ``per_second`` pays w2 x dt each control step (0.004 at 50 Hz; the
    training default: at 0.2 per step, watching the target pays more than catching it,
    measured in docs/model.md), ``per_step`` pays w2 each control step (eq. 9 as written)."""

    success_per: SuccessReading = static("terminal")
    """Reading of eq. 8: ``terminal`` pays w3 once, at the catch, which ends the episode (the
    default); ``every_step`` reads R_success as a state indicator, paid every control step
    while the target is within d_suc, and the episode runs to its time limit."""

    def visibility_weight(self, dt_s: float) -> float:
        """The weight of the visibility term per control step of ``dt_s`` seconds."""
        return self.visibility * (dt_s if self.visibility_per == "per_second" else 1.0)


@struct.dataclass
class EpisodeCfg:
    control_hz: int = static(50)
    """Rate of the high-level commands."""
    physics_substeps: int = static(4)
    """Base and arm sub-steps per control step (4 x 50 Hz = 200 Hz)."""
    duration_s: float = 20.0
    """Episode limit (open plane in the paper)."""
    init_distance_min_m: float = 2.0
    """Closest initial robot-target distance."""
    init_distance_max_m: float = 6.0
    """Farthest initial robot-target distance."""

    @property
    def dt_s(self) -> float:
        return 1.0 / self.control_hz

    @property
    def max_steps(self):
        return jnp_round(self.duration_s * self.control_hz)


def jnp_round(x):
    """Round a Python or JAX scalar to the nearest integer (int32 when traced)."""
    if isinstance(x, int | float):
        return int(round(x))
    import jax.numpy as jnp

    return jnp.round(x).astype(jnp.int32)


@struct.dataclass
class WorldCfg:
    """Everything the simulator needs; pass it to ``reset`` and ``step``."""

    scene: SceneCfg = SceneCfg()
    arena: ArenaCfg = ArenaCfg()
    room: RoomCfg = RoomCfg()
    woods: WoodsCfg = WoodsCfg()
    rough: TerrainCfg = ROUGH
    """The gait on rough ground (``woods_rough``)."""
    stairs: TerrainCfg = STAIRS
    """The gait on stairs (``woods_stairs``)."""
    avoid: AvoidCfg = AvoidCfg()
    base: BaseCfg = BaseCfg()
    arm: ArmCfg = ArmCfg()
    target: TargetCfg = TargetCfg()
    sensor: SensorCfg = SensorCfg()
    observation: ObservationCfg = ObservationCfg()
    reward: RewardCfg = RewardCfg()
    episode: EpisodeCfg = EpisodeCfg()

    def with_speed(self, speed_mps: float) -> WorldCfg:
        """The same world with the target speed fixed (as in the evaluation tables)."""
        return self.replace(
            target=self.target.replace(speed_min_mps=speed_mps, speed_max_mps=speed_mps)
        )

    def with_behavior(self, behavior: str) -> WorldCfg:
        """The same world with another target behaviour (``target.behavior``, the one field:
        ``--behavior`` on the command line), as grids over behaviours ask for it."""
        return self.replace(target=self.target.replace(behavior=behavior))

    def with_scene(self, scene: str) -> WorldCfg:
        """The same world in another scene (nothing else changes: the scan keeps its rays)."""
        return self.replace(scene=self.scene.replace(name=scene))

    def for_scene(self, scene: str) -> WorldCfg:
        """The world in ``scene`` with that scene's own episode length and ray count
        (``Scene.duration_s``, ``Scene.scan_rays``; a scene without its own ray count
        takes ``SceneCfg``'s default)."""
        s = get_scene(scene)
        rays = SceneCfg().scan_rays if s.scan_rays is None else s.scan_rays
        return self.replace(
            scene=self.scene.replace(name=scene, scan_rays=rays),
            episode=self.episode.replace(duration_s=s.duration_s),
        )
