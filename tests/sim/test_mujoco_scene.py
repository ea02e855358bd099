"""The MuJoCo scene is built from the hand file and the object profile (skipped without mujoco)."""

from __future__ import annotations

import mujoco  # a run-time dependency: no skip
import numpy as np
import pytest

from grasp_ctrl.controller.joint_stiffness import servo_kp_nm_per_rad, servo_kv_nm_s_per_rad  # noqa: E402
from grasp_ctrl.kinematics.chain import HandKinematics  # noqa: E402
from grasp_ctrl.sim.mujoco.scene import PlacedObject, SceneParams, build_scene, with_servo_facts  # noqa: E402


def _model(hand, obj, mu=None):
    placed = PlacedObject(obj, (0.0, 0.0), obj.mass_kg, mu or obj.mu, obj.stiffness_n_per_m)
    scene = build_scene(hand, placed, np.zeros(3))
    return scene, mujoco.MjModel.from_xml_string(scene.xml)


def test_sensor_sites_follow_the_hand_files_kinematics(hand, objects):
    scene, m = _model(hand, objects["lego"])
    d = mujoco.MjData(m)
    kin = HandKinematics(hand)
    lower = np.array([j.lower_rad for j in hand.joints])
    upper = np.array([j.upper_rad for j in hand.joints])
    adr = [m.jnt_qposadr[m.joint(name).id] for name in scene.joint_names]
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = rng.uniform(lower, upper)
        d.qpos[adr] = q
        mujoco.mj_kinematics(m, d)
        for i, finger in enumerate(scene.finger_names):
            T = kin.fk(finger, q)
            site = m.site(scene.sensor_sites[i]).id
            assert np.allclose(d.site_xpos[site], T[:3, 3], atol=1e-7)
            assert np.allclose(d.site_xmat[site].reshape(3, 3), T[:3, :3], atol=1e-7)


def test_joints_and_actuators_carry_the_hand_files_limits_and_gains(hand, objects):
    scene, m = _model(hand, objects["lego"])
    p = with_servo_facts(SceneParams(), hand)
    assert p.torque_per_amp_nm == pytest.approx(0.93 / 1.8)  # the hand file's XC330-M288-T data sheet
    kp = servo_kp_nm_per_rad(hand.dynamixel.position_p_gain)
    kv = servo_kv_nm_s_per_rad(hand.dynamixel.position_d_gain)
    assert 2.5 < kp < 4.0 and 0.005 < kv < 0.015  # LEAP sim / Menagerie: 3.0 and 0.01
    for j in hand.joints:
        jid, aid = m.joint(j.name).id, m.actuator(j.name).id
        assert np.allclose(m.jnt_range[jid], (j.lower_rad, j.upper_rad))
        tau = j.current_limit_a * p.torque_per_amp_nm
        assert np.allclose(m.actuator_forcerange[aid], (-tau, tau))
        assert m.actuator_gainprm[aid, 0] == pytest.approx(kp * j.gain_scale, rel=1e-5)
        assert m.actuator_biasprm[aid, 2] == pytest.approx(-kv * j.gain_scale, rel=1e-5)


def test_object_body_has_the_profiles_mass_size_and_friction(hand, objects):
    obj = objects["mustard_bottle"]
    scene, m = _model(hand, obj, mu=0.77)
    body = m.body("object").id
    assert m.body_mass[body] == pytest.approx(obj.mass_kg)
    g = m.geom("object_body").id
    assert np.allclose(2 * m.geom_size[g], (*obj.size_m, obj.height_m))
    assert m.geom_friction[g][0] == pytest.approx(0.77)
    assert "object_cap" in scene.object_geoms  # the dome on top
    cap = m.geom("object_cap").id
    top = m.geom_pos[cap][2] + m.geom_size[cap][0]
    assert top == pytest.approx(obj.height_m + obj.cap.height_m)
    # Hand-object contacts take the object's friction (priority), never the hand's.
    assert m.geom_priority[g] > m.geom_priority[m.geom(scene.biotac_geoms[0]).id]


def test_deformable_objects_touch_softer(hand, objects):
    _, rigid = _model(hand, objects["lego"])
    _, cup = _model(hand, objects["paper_cup"])
    assert cup.geom_solref[cup.geom("object_body").id][0] > rigid.geom_solref[rigid.geom("object_body").id][0]
