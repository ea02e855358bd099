"""A trial's messages, from its tick log, record and hand (docs/ros_bags.md).

Every tick of the log gives one message on each per-tick topic, stamped with the tick's
time ``t`` (s of trial time, from 0): the joint states and goals, each fingertip's estimated
(and, in simulation, true) force in its sensor frame, the controller's state, the object's
pose (where logged), the hand's frames on ``/tf`` and the raw tactile frames (where the log
holds them whole). The record's transitions and the world's events come at their own times.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from typing import Any

import numpy as np

from grasp_ctrl.bags import messages as m
from grasp_ctrl.bags import topics
from grasp_ctrl.bags.types import BIOTAC_HAND, JOINT_STATE, POSE_STAMPED, STRING, TF_MESSAGE, WRENCH_STAMPED
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.loop.ticklog import raw_frame_columns
from grasp_ctrl.trials.analysis.trial_view import TrialView


def tick_times_ns(view: TrialView) -> np.ndarray:
    """The ticks' times in ns (the bag's clock)."""
    return np.round(np.asarray(view.t, dtype=float) * 1e9).astype(np.int64)


def _cols(view: TrialView, names: list[str]) -> np.ndarray | None:
    """The columns side by side as (T, k) floats, or None when one is missing."""
    if not all(view.has(c) for c in names):
        return None
    return np.stack([np.asarray(view.cols[c], dtype=float) for c in names], axis=1)


def has_raw_frames(view: TrialView) -> bool:
    return all(view.has(c) for f in view.fingers for c in raw_frame_columns(f))


def _quat_batch(R_fixed: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Quaternions (x, y, z, w) of R_fixed @ Rot(axis, angle) for every angle: (T, 4)."""
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(angles[:, None] * np.asarray(axis, dtype=float)[None, :])
    return (Rotation.from_matrix(R_fixed) * turn).as_quat()


def _quat(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_quat()


class _HandFrames:
    """The hand's transforms per tick: world -> hand (the palm's logged position), hand ->
    each finger's base, each joint's link (its origin, then its turn by the logged angle),
    and the last link -> the fingertip's sensor frame."""

    def __init__(self, view: TrialView, hand: HandConfig) -> None:
        from grasp_ctrl.kinematics.chain import HandKinematics

        kin = HandKinematics(hand)
        n_joints = len(hand.joints)
        q = _cols(view, [f"q{j}" for j in range(n_joints)])
        palm = _cols(view, [f"palm_{a}_world" for a in "xyz"])
        n = len(view.t)
        self.palm = palm if palm is not None else np.zeros((n, 3))
        # (parent, child, translation (3,), quaternions (T, 4) or (4,) when fixed)
        self.edges: list[tuple[str, str, np.ndarray, np.ndarray]] = []
        for finger in hand.fingers:
            chain = kin.chains[finger.name]
            parent = topics.base_frame(finger.name)
            self.edges.append((topics.HAND_FRAME, parent, chain.T_hand_base[:3, 3], _quat(chain.T_hand_base[:3, :3])))
            cols = range(n_joints)[kin.slices[finger.name]]
            for i, joint in enumerate(finger.joints):
                angles = q[:, cols[i]] if q is not None else np.zeros(n)
                child = topics.link_frame(joint.name)
                T = chain.T_origins[i]
                self.edges.append((parent, child, T[:3, 3], _quat_batch(T[:3, :3], chain.axes[i], angles)))
                parent = child
            tip = topics.sensor_frame(finger.name)
            self.edges.append((parent, tip, chain.T_tip[:3, 3], _quat(chain.T_tip[:3, :3])))

    def message(self, k: int, t_ns: int) -> dict[str, Any]:
        out = [m.transform(t_ns, topics.WORLD_FRAME, topics.HAND_FRAME, self.palm[k], (0.0, 0.0, 0.0, 1.0))]
        for parent, child, p, quats in self.edges:
            out.append(m.transform(t_ns, parent, child, p, quats[k] if quats.ndim == 2 else quats))
        return {"transforms": out}


def _timed_strings(view: TrialView) -> list[m.Message]:
    """The controller's transitions (the record's, else the log's state changes) and the world's events."""
    rec = view.record or {}
    out: list[m.Message] = []
    transitions = rec.get("transitions")
    if transitions is None:
        states = view.states
        transitions = [
            (view.t[i], states[i - 1], states[i]) for i in range(1, len(states)) if states[i] != states[i - 1]
        ]
    for t, src, dst in transitions:
        t_ns = int(round(float(t) * 1e9))
        out.append((t_ns, topics.CONTROLLER_TRANSITIONS, STRING, m.string(f"{src} -> {dst}")))
    for event in rec.get("events", []):
        t_ns = int(round(float(event.get("t", 0.0)) * 1e9))
        text = f"{event.get('kind')}: {event.get('detail', '')}".rstrip(": ")
        out.append((t_ns, topics.TRIAL_EVENTS, STRING, m.string(text)))
    return sorted(out, key=lambda msg: msg[0])


def trial_messages(view: TrialView, hand: HandConfig) -> Iterator[m.Message]:
    """Every message of the trial's bag, in time order."""
    return heapq.merge(_tick_messages(view, hand), _timed_strings(view), key=lambda msg: msg[0])


def _tick_messages(view: TrialView, hand: HandConfig) -> Iterator[m.Message]:
    t_ns = tick_times_ns(view)
    n_joints = len(hand.joints)
    names = [j.name for j in hand.joints]
    q = _cols(view, [f"q{j}" for j in range(n_joints)])
    q_goal = _cols(view, [f"q_goal{j}" for j in range(n_joints)])
    current_a = _cols(view, [f"current{j}" for j in range(n_joints)])
    forces: list[tuple[str, str, np.ndarray]] = []  # (topic, sensor frame, (T, 3) N)
    for finger in view.fingers:
        for kind, prefix in (("estimated", ""), ("true", "true_")):
            f_sensor = _cols(view, [f"{finger}_{prefix}f{a}_sensor" for a in "xyz"])
            if f_sensor is not None:
                forces.append((topics.force_topic(finger, kind), topics.sensor_frame(finger), f_sensor))
    obj_z = np.asarray(view.cols["object_z_world"], dtype=float) if view.has("object_z_world") else None
    frames = _HandFrames(view, hand)
    raw: list[tuple[str, int, np.ndarray]] | None = None
    if has_raw_frames(view):
        sensor_ids = {f.name: f.sensor_id for f in hand.fingers}
        raw = []
        for f in view.fingers:
            counts = _cols(view, raw_frame_columns(f))
            assert counts is not None  # has_raw_frames: every column is there
            raw.append((f, sensor_ids[f], counts))
    states = view.states
    q_list = q.tolist() if q is not None else None
    goal_list = q_goal.tolist() if q_goal is not None else None
    amps = current_a.tolist() if current_a is not None else None
    # a tick whose currents the hand did not report (NaN in the log) has an empty effort
    amps_ok = np.isfinite(current_a).all(axis=1).tolist() if current_a is not None else None
    for k, tk in enumerate(t_ns.tolist()):
        if q_list is not None:
            effort = amps[k] if amps is not None and amps_ok is not None and amps_ok[k] else []
            yield tk, topics.JOINT_STATES, JOINT_STATE, m.joint_state(tk, names, q_list[k], effort)
        if goal_list is not None:
            yield tk, topics.JOINT_GOALS, JOINT_STATE, m.joint_state(tk, names, goal_list[k], [])
        for topic, frame, f_sensor in forces:
            yield tk, topic, WRENCH_STAMPED, m.wrench_stamped(tk, frame, f_sensor[k])
        yield tk, topics.CONTROLLER_STATE, STRING, m.string(states[k])
        if obj_z is not None:
            pose = m.pose_stamped(tk, topics.WORLD_FRAME, (0.0, 0.0, obj_z[k]))
            yield tk, topics.OBJECT_POSE, POSE_STAMPED, pose
        yield tk, topics.TF, TF_MESSAGE, frames.message(k, tk)
        if raw is not None:
            # a tick whose frame a fingertip did not deliver (NaN in the log) has no entry for it
            data = [m.biotac_data(name, sid, np.rint(c[k])) for name, sid, c in raw if np.isfinite(c[k]).all()]
            yield tk, topics.BIOTAC, BIOTAC_HAND, m.biotac_hand(tk, hand.name, data)
