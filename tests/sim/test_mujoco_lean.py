"""The MuJoCo world's one-call tick (sim/mujoco/tick_kernel.py's mj_tick_frames) against a
straightforward reference: tests/mujoco_contacts_reference.py's read_contacts and skin_point_and_normal,
a loop per fingertip on Python floats and the BioTac model's own ``frames``."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from mujoco_contacts_reference import read_contacts, skin_point_and_normal

from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick
from grasp_ctrl.sim.mujoco.backends import mujoco_backends
from grasp_ctrl.sim.mujoco.tick_kernel import (
    NEW_CONTACT,
    SUM_FLAGS,
    SUM_ON_TABLE,
    SUM_OTHER_N,
    SUM_PEAK_OTHER_N,
    SUM_TABLE_N,
    mj_body_velocity,
    mj_skin_point,
)
from grasp_ctrl.sim.mujoco.world import MuJoCoWorld, mocap_step
from grasp_ctrl.sim.oracle import OracleEstimator
from grasp_ctrl.sim.world_backends import WorldArm


def _bits(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=float)).view(np.int64)


def _rt_v(R: list[float], v: list[float]) -> list[float]:
    """R^T v for a row-major 3x3 R, summed left to right from 0.0."""
    return [0.0 + R[c] * v[0] + R[3 + c] * v[1] + R[6 + c] * v[2] for c in range(3)]


def _r_v(R: list[float], v: list[float]) -> list[float]:
    return [0.0 + R[3 * r] * v[0] + R[3 * r + 1] * v[1] + R[3 * r + 2] * v[2] for r in range(3)]


class ReferenceWorld(MuJoCoWorld):
    """The tick's sensing written out plainly, one fingertip at a time."""

    def _sense(self) -> np.ndarray:
        m, d, n = self.model, self.data, len(self.fingers)
        c = read_contacts(m, d, self._tip_geom_of.tolist(), self._object_geom.tolist(), self._table, n)
        was = self._touch_obj.copy()
        self._f_world[:] = c.f_world
        self._normal_n[:] = c.normal_from_object_n
        self._in_contact[:] = c.touching
        self._touch_obj[:] = c.touching_object
        self._new_contacts[:] = self._touch_obj & ~was
        sums = self._sums  # what _record and the properties read (SUM_TABLE_N .. SUM_FLAGS)
        sums[SUM_TABLE_N] = c.table_normal_on_object_n
        sums[SUM_ON_TABLE] = 1.0 if c.object_on_table else 0.0
        sums[SUM_OTHER_N] = c.other_hand_on_object_n
        sums[SUM_PEAK_OTHER_N] = max(sums[SUM_PEAK_OTHER_N], c.other_hand_on_object_n)
        sums[SUM_FLAGS] = NEW_CONTACT if self._new_contacts.any() else 0
        obj = int(self._obj_body)
        for i in range(n):
            s = int(self._sites[i])
            R, o = d.site_xmat[s].tolist(), d.site_xpos[s].tolist()
            self._f_sensor[i] = _rt_v(R, c.f_world[i].tolist())
            self._slip_speed[i] = 0.0
            if not c.touching[i]:
                continue
            rel = (c.point_world[i] - d.site_xpos[s]).tolist()
            p_s, n_s = skin_point_and_normal(np.array(_rt_v(R, rel)))
            self._contact_sensor[i] = p_s
            self._skin_normal_sensor[i] = n_s
            if not c.touching_object[i]:
                continue
            p_w = [a + b for a, b in zip(_r_v(R, p_s.tolist()), o)]
            n_w = _r_v(R, n_s.tolist())
            rel_v = [0.0, 0.0, 0.0]
            for body, sign in ((int(self._tip_bodies[i]), 1.0), (obj, -1.0)):
                wx, wy, wz, v3, v4, v5 = mj_body_velocity(body, d.cvel, d.xipos, d.subtree_com, m.body_rootid)
                rx, ry, rz = (p - b for p, b in zip(p_w, d.xpos[body].tolist()))
                rel_v[0] += sign * (v3 + wy * rz - wz * ry)
                rel_v[1] += sign * (v4 + wz * rx - wx * rz)
                rel_v[2] += sign * (v5 + wx * ry - wy * rx)
            along = 0.0 + ((rel_v[0] * n_w[0] + rel_v[1] * n_w[1]) + rel_v[2] * n_w[2])
            t = [rel_v[k] - along * n_w[k] for k in range(3)]
            self._slip_speed[i] = math.sqrt(0.0 + ((t[0] * t[0] + t[1] * t[1]) + t[2] * t[2]))
        self.seq = (self.seq + 1) & 0xFFFF
        return self.sensors.frames(
            self._contact_sensor, self._f_sensor, self._skin_normal_sensor, self._in_contact, self._slip_speed, self.dt
        )


@pytest.fixture(scope="module")
def lockstep(hand, objects):
    """The world and the reference world stepped with the same commands through the
    approach, the grasp and the start of the lift; per tick, what each reports."""
    obj = objects["chips_can"]
    world, ref = MuJoCoWorld(hand, obj, 3), ReferenceWorld(hand, obj, 3)
    kin = HandKinematics(hand)
    hand_backend, sensors = mujoco_backends(world, hand)
    arm = WorldArm(world, hand)
    pipeline = SensingPipeline(hand, kin, OracleEstimator(world))
    ctrl = GraspController(hand, obj, world.reach_pose_world(), kin=kin)
    ticks = []
    for _ in range(420):
        world.step()
        ref.step()
        ticks.append((world, ref, _snapshot(world), _snapshot(ref)))
        if not ctrl.terminal:
            control_tick(hand_backend, arm, sensors, pipeline, ctrl, world.t)
        ref.command_goal(world.q_goal_measured)
        ref.palm_target = world.palm_target
        ref.torque_on = world.torque_on
        ref.set_phase(world.phase)
    return ticks


def _snapshot(w: MuJoCoWorld) -> dict[str, object]:
    return {
        "raw": w.raw.copy(),
        "f_world": w.f_world.copy(),
        "f_sensor": w.f_sensor.copy(),
        "normal": w.normal_n.copy(),
        "touching": w.in_contact.copy(),
        "contact": w.contact_sensor.copy(),
        "skin_normal": w.skin_normal_sensor.copy(),
        "slip": w.slip_speed.copy(),
        "sums": (w.table_n, w._sums.item(SUM_ON_TABLE) > 0.0, w.other_hand_contact_n, w.peak_other_hand_contact_n),
        "qpos": w.data.qpos.copy(),
        "events": len(w.events),
    }


def test_the_lockstep_reaches_contact(lockstep):
    touching = [s["touching"].sum() for _, _, s, _ in lockstep]
    assert max(touching) >= 3  # the grasp is on: the comparisons below cover contacts
    assert any(s["slip"].max() > 0.0 for _, _, s, _ in lockstep)


def test_the_tick_kernel_gives_the_reference_bits(lockstep):
    for k, (_, _, got, want) in enumerate(lockstep):
        for key in ("f_world", "f_sensor", "normal", "contact", "skin_normal", "slip", "qpos"):
            assert np.array_equal(_bits(got[key]), _bits(want[key])), (k, key)
        assert np.array_equal(got["touching"], want["touching"]), k
        assert np.array_equal(got["raw"], want["raw"]), k
        assert got["sums"] == want["sums"], k
        assert got["events"] == want["events"], k


def test_the_events_match(lockstep):
    world, ref = lockstep[-1][0], lockstep[-1][1]
    assert world.events == ref.events and world.max_obj_z == ref.max_obj_z


def test_body_velocity_is_mujocos(lockstep):
    """mj_body_velocity is mj_objectVelocity (mjOBJ_BODY, world frame); C and numba may
    round a product apart, hence the tolerance."""
    world = lockstep[-1][0]
    m, d = world.model, world.data
    res = np.empty(6)
    for body in range(1, m.nbody):
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, res, 0)
        got = mj_body_velocity(body, d.cvel, d.xipos, d.subtree_com, m.body_rootid)
        np.testing.assert_allclose(got, res, rtol=1e-12, atol=1e-15)


def test_the_products_agree_with_numpy(lockstep):
    """The 3x3 products summed left to right agree with numpy's (einsum, BLAS matmul), which
    may sum in another order or fuse multiply-adds: equal within rounding."""
    world = lockstep[-1][0]
    d = world.data
    R_all = d.site_xmat[world._sites].reshape(-1, 3, 3)
    np.testing.assert_allclose(world.f_sensor, np.einsum("nji,nj->ni", R_all, world.f_world), rtol=1e-12, atol=1e-15)
    for i in np.flatnonzero(world.in_contact):
        p_w = R_all[i] @ world.contact_sensor[i] + d.site_xpos[world._sites[i]]
        back = R_all[i].T @ (p_w - d.site_xpos[world._sites[i]])
        np.testing.assert_allclose(back, world.contact_sensor[i], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize(
    "p",
    [
        (0.003, 0.001, -0.002),
        (1e-12, 0.0, 0.0),
        (0.0, 0.004, -0.003),
        (-0.0, -0.004, 0.003),
        (-0.02, 0.0, -0.006),
        (-0.005, 0.0, 0.0),
        (-0.005, -0.0, -0.0),
        (-0.014, 0.001, -0.0055),
    ],
)
def test_the_skin_point_is_skin_point_and_normal(p):
    want_p, want_n = skin_point_and_normal(np.array(p))
    got = mj_skin_point(*p, SKIN_RADIUS_M, PAD_X_MIN_M)
    assert np.array_equal(_bits(got[:3]), _bits(want_p)) and np.array_equal(_bits(got[3:]), _bits(want_n))


class _StepInputs:
    """The mujoco module, noting the mocap position each of mj_step's steps is taken with."""

    def __init__(self) -> None:
        self.mocap: list[np.ndarray] = []

    def __getattr__(self, name: str):  # noqa: ANN204
        return getattr(mujoco, name)

    def mj_step(self, m, d, nstep: int = 1) -> None:  # noqa: ANN001
        self.mocap.extend([d.mocap_pos.copy()] * nstep)
        mujoco.mj_step(m, d, nstep)


def test_the_substeps_move_the_mocap_as_one_move_per_substep(hand, objects):
    w = MuJoCoWorld(hand, objects["lego"], 2)
    steps = _StepInputs()
    w._mj = steps
    target = w.data.mocap_pos[w._mocap] + np.array([0.003, -0.002, -0.004])  # reached in a few ticks
    w.palm_target = target
    max_move = w.arm_speed * w.model.opt.timestep
    expected = [w.data.mocap_pos[w._mocap].tolist()]
    for _ in range(40):  # moving, arriving and resting at the target
        w.step()
    for _ in range(40 * w._substeps):
        expected.append(list(mocap_step(expected[-1], *target.tolist(), max_move)))
    got = [p[w._mocap] for p in steps.mocap]
    assert len(got) == 40 * w._substeps
    assert np.array_equal(_bits(got), _bits(expected[1:]))
    assert np.array_equal(got[-1], target)
