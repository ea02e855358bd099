"""The shipped Allegro hand file against MuJoCo Menagerie's Allegro model and SimLab's driver.

Kinematics: MuJoCo Menagerie's ``wonik_allegro/right_hand.xml`` in ../shared/data/allegro_hand
(skipped when absent), loaded by MuJoCo itself. The hand file's palm placement is its own choice,
so the comparison fits the one rigid transform between the two palm frames, then checks every
joint: its origin on the XML joint's axis line within 1 mm, its axis within 1 degree, its limits
equal, and each finger's chain the XML's, joint by joint from the palm.

Actuation: the gains and torque limits are SimLab allegro_hand_ros_v4's numbers in SI (its
gains_pd.yaml and AllegroHandDrv.cpp, v4: 1200 PWM units per N m), with the far joints' and the
thumb's PWM limits raised as IIT's allegro_hrii setup raises them (400 x 1.5), never above the
driver's 12 V ceiling of 1200.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.actuation import pd_gains, torque_limits_nm, torque_per_amp_nm
from grasp_ctrl.config.hand import HandConfig, load_hand
from grasp_ctrl.files.paths import hand_configs_dir
from grasp_ctrl.kinematics import HandKinematics
from tests.kinematics.test_leap_urdf import worst_joint_offsets

mujoco = pytest.importorskip("mujoco")

FINGER_PREFIX = {"index": "ff", "middle": "mf", "ring": "rf", "thumb": "th"}


@pytest.fixture(scope="module")
def allegro() -> HandConfig:
    return load_hand(hand_configs_dir() / "allegro_hand.toml")


@pytest.fixture
def menagerie(shared_data: Path):  # type: ignore[no-untyped-def]
    path = shared_data / "allegro_hand" / "mujoco_menagerie" / "right_hand_kinematic.xml"
    if not path.is_file():
        pytest.skip(f"{path} is not present")
    return mujoco.MjModel.from_xml_path(str(path))


def _xml_axes_and_origins(m, d, names: list[str]) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """Joint axes and anchors in the XML's palm frame."""
    palm = m.body("palm").id
    R_palm, p_palm = d.xmat[palm].reshape(3, 3), d.xpos[palm]
    ids = [m.joint(n).id for n in names]
    axes = np.array([R_palm.T @ d.xaxis[i] for i in ids])
    origins = np.array([R_palm.T @ (d.xanchor[i] - p_palm) for i in ids])
    return axes, origins


def test_hand_file_matches_menageries_allegro(allegro: HandConfig, menagerie) -> None:  # type: ignore[no-untyped-def]
    m = menagerie
    d = mujoco.MjData(m)
    kin = HandKinematics(allegro)
    for f in allegro.fingers:
        names = [j.name for j in f.joints]
        assert names == [f"{FINGER_PREFIX[f.name]}j{k}" for k in range(4)], f.name
        for j in f.joints:  # limits equal, chain order from the palm: each joint's body is the next one's parent
            lo, hi = m.jnt_range[m.joint(j.name).id]
            assert (j.lower_rad, j.upper_rad) == pytest.approx((lo, hi), abs=1e-9), j.name
        bodies = [m.jnt_bodyid[m.joint(n).id] for n in names]
        assert [m.body_parentid[b] for b in bodies[1:]] == bodies[:-1], f.name

    rng = np.random.default_rng(0)
    lower = np.array([j.lower_rad for j in allegro.joints])
    upper = np.array([j.upper_rad for j in allegro.joints])
    xml_qadr = [m.jnt_qposadr[m.joint(j.name).id] for j in allegro.joints]
    samples = []
    for _ in range(20):
        q_all = rng.uniform(lower, upper)
        d.qpos[xml_qadr] = q_all
        mujoco.mj_kinematics(m, d)
        for f in allegro.fingers:
            a_hand, o_hand = kin.chains[f.name].joint_axes_and_origins(q_all[kin.slices[f.name]])
            a_xml, o_xml = _xml_axes_and_origins(m, d, [j.name for j in f.joints])
            samples.append((a_hand, o_hand, a_xml, o_xml))
    worst_mm, worst_deg = worst_joint_offsets(samples)
    assert worst_mm < 1.0, f"joint origins off the XML's axes by up to {worst_mm:.3f} mm"
    assert worst_deg < 1.0, f"joint axes off the XML's by up to {worst_deg:.3f} deg"


def test_collision_boxes_are_menageries(allegro: HandConfig, menagerie) -> None:  # type: ignore[no-untyped-def]
    m = menagerie
    for j in allegro.joints:
        boxes = allegro.boxes_of(j.name)
        assert boxes is not None and len(boxes) == 1, j.name
        body = m.jnt_bodyid[m.joint(j.name).id]
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
        assert len(geoms) == 1, j.name
        assert boxes[0].half_m == pytest.approx(tuple(m.geom_size[geoms[0]]), abs=1e-9), j.name
        assert boxes[0].pos_m == pytest.approx(tuple(m.geom_pos[geoms[0]]), abs=1e-9), j.name


def test_actuation_is_simlabs_driver_in_si(allegro: HandConfig) -> None:
    assert allegro.actuator == "torque_pd"
    assert torque_per_amp_nm(allegro) is None  # the v4 reports no current
    gains = pd_gains(allegro)
    assert gains.kp_nm_per_rad is not None and gains.kv_nm_s_per_rad is not None
    # gains_pd.yaml: p 4000 on every joint; d 150, 200 on joint 1, thumb 300/200/200/150 (PWM units)
    assert np.allclose(gains.kp_nm_per_rad, 4000.0 / 1200.0)
    d_pwm = [150, 200, 150, 150] * 3 + [300, 200, 200, 150]
    assert np.allclose(gains.kv_nm_s_per_rad, np.array(d_pwm) / 1200.0)
    # AllegroHandDrv.cpp: PWM limits (roll, near, middle, far; the thumb's) x 1.5, at 1200 PWM per N m;
    # stock: far 190, thumb 350, 270, 180, 180; raised (allegro_hrii): far and thumb 400
    pwm = [250, 450, 300, 400] * 3 + [400, 400, 400, 400]
    assert np.allclose(torque_limits_nm(allegro), 1.5 * np.array(pwm) / 1200.0)
    assert np.all(1200.0 * torque_limits_nm(allegro) <= 1200.0)  # the driver's global PWM limit at 12 V


def test_the_grasp_is_index_middle_and_thumb(allegro: HandConfig) -> None:
    assert [f.name for f in allegro.grasp_fingers] == ["index", "middle", "thumb"]
    assert allegro.grasp.release_finger == "index"
