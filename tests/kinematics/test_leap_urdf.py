"""The shipped LEAP hand file against the LEAP Hand's own URDF (../shared/data/leap_hand).

The hand file's palm placement is its own choice, so the comparison first fits the
rigid transform between the two palm frames, then checks every joint: its origin
on the URDF joint's axis line within 1 mm, its axis within 1 degree, its limits
equal, and the chain order from the palm the URDF's.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.kinematics import HandKinematics
from grasp_ctrl.kinematics.transforms import axis_angle, rpy_matrix


@dataclass(frozen=True)
class UrdfJoint:
    name: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float


def read_urdf(path: Path) -> dict[str, UrdfJoint]:
    joints = {}
    for j in ET.parse(path).getroot().iter("joint"):
        origin, limit = j.find("origin"), j.find("limit")
        joints[j.get("name")] = UrdfJoint(
            name=j.get("name"),
            parent=j.find("parent").get("link"),
            child=j.find("child").get("link"),
            xyz=np.array(origin.get("xyz").split(), dtype=float),
            rpy=np.array(origin.get("rpy").split(), dtype=float),
            axis=np.array(j.find("axis").get("xyz").split(), dtype=float),
            lower=float(limit.get("lower")),
            upper=float(limit.get("upper")),
        )
    return joints


def urdf_chain(joints: dict[str, UrdfJoint], first: str) -> list[UrdfJoint]:
    """The serial chain that starts with joint ``first`` and follows child links."""
    chain = [joints[first]]
    while True:
        nxt = [j for j in joints.values() if j.parent == chain[-1].child]
        if not nxt:
            return chain
        chain.append(nxt[0])


def urdf_axes_and_origins(chain: list[UrdfJoint], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axes and origins of the chain's joints in the URDF's root (palm) frame."""
    R, p = np.eye(3), np.zeros(3)
    axes, origins = [], []
    for j, qi in zip(chain, q):
        p = p + R @ j.xyz
        R = R @ rpy_matrix(j.rpy)
        axes.append(R @ j.axis)
        origins.append(p)
        R = R @ axis_angle(j.axis, float(qi))
    return np.array(axes), np.array(origins)


def rigid_fit(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R, t minimising |R a + t - b| (Kabsch)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    U, _, Vt = np.linalg.svd((a - ca).T @ (b - cb))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    return R, cb - R @ ca


def worst_joint_offsets(samples: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """(hand axes, hand origins, reference axes, reference origins) per sample, hand frame and the
    reference's palm frame: after the one rigid fit between the palm frames, the largest distance
    (mm) of a joint origin from the reference joint's axis line (an origin may sit anywhere on its
    axis) and the largest angle (deg) between axes."""
    R, t = rigid_fit(np.vstack([s[3] for s in samples]), np.vstack([s[1] for s in samples]))
    worst_mm = worst_deg = 0.0
    for a_hand, o_hand, a_ref, o_ref in samples:
        a_r, o_r = a_ref @ R.T, o_ref @ R.T + t
        d = o_hand - o_r
        off_line = d - np.sum(d * a_r, axis=1, keepdims=True) * a_r
        worst_mm = max(worst_mm, 1000 * float(np.max(np.linalg.norm(off_line, axis=1))))
        cos = np.clip(np.sum(a_hand * a_r, axis=1), -1.0, 1.0)
        worst_deg = max(worst_deg, float(np.degrees(np.max(np.arccos(cos)))))
    return worst_mm, worst_deg


@pytest.fixture
def urdf(shared_data: Path) -> dict[str, UrdfJoint]:
    path = shared_data / "leap_hand" / "LEAP_Hand_Sim" / "robot.urdf"
    if not path.is_file():
        pytest.skip(f"{path} is not present")
    return read_urdf(path)


def test_hand_file_matches_the_leap_urdf(hand: HandConfig, urdf: dict[str, UrdfJoint]) -> None:
    kin = HandKinematics(hand)
    rng = np.random.default_rng(0)
    chains = {}
    for f in hand.fingers:
        ids = [str(j.servo_id) for j in f.joints]
        chain = urdf_chain(urdf, ids[0])
        # Same joints in the same order from the palm (servo id N = URDF joint "N").
        assert [j.name for j in chain] == ids, f.name
        assert chain[0].parent == "palm_lower"
        for jc, ju in zip(f.joints, chain):
            assert (jc.lower_rad, jc.upper_rad) == (ju.lower, ju.upper), jc.name
        chains[f.name] = chain

    # Random postures within the limits; the palm frames are related by one rigid transform.
    samples = []
    for _ in range(20):
        q_all = rng.uniform([j.lower_rad for j in hand.joints], [j.upper_rad for j in hand.joints])
        for f in hand.fingers:
            q = q_all[kin.slices[f.name]]
            a_hand, o_hand = kin.chains[f.name].joint_axes_and_origins(q)
            a_urdf, o_urdf = urdf_axes_and_origins(chains[f.name], q)
            samples.append((a_hand, o_hand, a_urdf, o_urdf))
    worst_mm, worst_deg = worst_joint_offsets(samples)
    assert worst_mm < 1.0, f"joint origins off the URDF axes by up to {worst_mm:.3f} mm"
    assert worst_deg < 1.0, f"joint axes off the URDF's by up to {worst_deg:.3f} deg"


def test_servo_ids_follow_the_leap_api(hand: HandConfig) -> None:
    ids = {f.name: sorted(j.servo_id for j in f.joints) for f in hand.fingers}
    assert ids == {"index": [0, 1, 2, 3], "middle": [4, 5, 6, 7], "ring": [8, 9, 10, 11], "thumb": [12, 13, 14, 15]}
    for f in hand.fingers:
        if f.name != "thumb":  # flexion (MCP) before abduction along each finger
            assert [j.servo_id % 4 for j in f.joints] == [1, 0, 2, 3], f.name
    for j in hand.joints:  # the LEAP API's limits; the binding thumb MCP may go to 1.2 A (hand file header)
        assert 0.35 <= j.current_limit_a <= (1.2 if j.name == "thumb_mcp" else 0.55), j.name
