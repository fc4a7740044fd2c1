"""Resources never doubly used; emotion changes arm swing and speed; blending; specificity order;
capabilities report running / success / failure."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.body import Status
from pedvr.body import actions as act
from pedvr.body import pose as ps
from pedvr.body import skeleton as sk
from pedvr.body.coordinator import Coordinator, default_choreographers, order_by_specificity
from pedvr.body.style import EMOTIONS, SPEED_FACTOR, one_hot, speed_factor
from pedvr.errors import UsageError
from tests.body._walk import bodies, drive


def test_resource_conflicts_never_run_two_actions_on_one_resource() -> None:
    rng = np.random.default_rng(0)
    n, q, r = 50, act.QUEUE, act.N_RES
    q_kind = np.full((n, q), -1, np.int64)
    q_prio, q_wait, q_dur = np.zeros((n, q)), np.zeros((n, q)), np.zeros((n, q))
    q_planned = np.zeros((n, q), np.bool_)
    run_kind = np.full((n, r), -1, np.int64)
    run_end, run_mask = np.zeros((n, r)), np.zeros((n, r), np.int64)
    itch = np.zeros((n, act.N_ACTIONS))
    rates = np.full((n, act.N_ACTIONS), 0.5)  # very busy agents
    right = rng.random(n) < 0.5
    launched = 0
    dt = 1 / 30
    for k in range(3000):
        t = k * dt
        blocked = np.where(rng.random(n) < 0.2, act.HEAD, 0).astype(np.int64)
        arrive = np.empty((n, act.N_ACTIONS), np.bool_)
        act.arrivals(rates, rng.random((n, act.N_ACTIONS)), dt, arrive)
        started = np.empty((n, r), np.bool_)
        act.schedule_kernel(t, dt, arrive, rng.gamma(4.0, 0.75, (n, act.N_ACTIONS)), right, blocked, q_kind,
                            q_prio, q_wait, q_planned, q_dur, run_kind, run_end, run_mask, act.ALTERNATIVES, itch,
                            started)
        launched += int(started.sum())
        for i in range(n):
            masks = run_mask[i][run_kind[i] >= 0]
            total = 0
            for m in masks:
                assert (total & m) == 0, (k, i, run_kind[i], run_mask[i])
                total |= m
            # a running action holds one of its own alternative sets
            for kind, m in zip(run_kind[i], run_mask[i], strict=True):
                if kind >= 0:
                    assert m in act.ALTERNATIVES[kind]
    assert launched > 1000


def test_planned_actions_win_and_urgency_grows() -> None:
    n = 1
    q_kind = np.full((n, act.QUEUE), -1, np.int64)
    q_prio, q_wait, q_dur = np.zeros((n, act.QUEUE)), np.zeros((n, act.QUEUE)), np.full((n, act.QUEUE), 2.0)
    q_planned = np.zeros((n, act.QUEUE), np.bool_)
    q_kind[0, :2] = (act.A_HEAD_SCRATCH, act.A_HEAD_TOUCH)
    q_planned[0, 1] = True
    run_kind = np.full((n, act.N_RES), -1, np.int64)
    run_end, run_mask = np.zeros((n, act.N_RES)), np.zeros((n, act.N_RES), np.int64)
    itch = np.zeros((n, act.N_ACTIONS))
    none = np.zeros((n, act.N_ACTIONS), np.bool_)
    dur = np.zeros((n, act.N_ACTIONS))
    started = np.empty((n, act.N_RES), np.bool_)
    # the head is held by something else: both wait, the subconscious one grows more urgent
    act.schedule_kernel(0.0, 1.0, none, dur, np.array([True]), np.array([act.HEAD]),
                        q_kind, q_prio, q_wait, q_planned, q_dur, run_kind, run_end, run_mask,
                        act.ALTERNATIVES, itch, started)
    assert (run_kind < 0).all() and itch[0, act.A_HEAD_SCRATCH] > 0 and not started.any()
    act.schedule_kernel(1.0, 1 / 30, none, dur, np.array([True]), np.array([0]),
                        q_kind, q_prio, q_wait, q_planned, q_dur, run_kind, run_end, run_mask,
                        act.ALTERNATIVES, itch, started)
    running = set(run_kind[0][run_kind[0] >= 0].tolist())
    assert act.A_HEAD_TOUCH in running  # planned first (both need the head)
    assert act.A_HEAD_SCRATCH not in running


def _swing(emotion: str, speed: float) -> tuple[float, float]:
    b = bodies(1, emotion=one_hot(emotion))
    z = []

    def rec(bb, t):
        st = bb.state
        if t > 3.0:
            rel = st.world_pos[0, sk.L_WRIST] - st.world_pos[0, sk.PELVIS]
            z.append(rel[0])  # walking along 2D +x = 3D +X: the fore-aft axis

    drive(b, lambda t: np.array([[speed, 0.0]]), lambda t: np.zeros(1), 6.0, record=rec)
    return float(np.ptp(z)), float(speed_factor(one_hot(emotion))[0])


def test_emotion_changes_arm_swing_and_speed() -> None:
    # each walks at its own emotional speed (pref_speed × factor), as in the simulation
    amp = {e: _swing(e, 1.3 * SPEED_FACTOR[EMOTIONS.index(e)]) for e in ("sad", "neutral", "happy")}
    assert amp["sad"][0] < amp["neutral"][0] < amp["happy"][0], amp
    assert amp["sad"][1] < amp["neutral"][1] < amp["happy"][1], amp
    # and at the same speed the style alone orders the swing
    same = {e: _swing(e, 1.2)[0] for e in ("sad", "neutral", "happy")}
    assert same["sad"] < same["neutral"] < same["happy"], same


def test_blending_is_order_independent() -> None:
    rng = np.random.default_rng(5)
    from scipy.spatial.transform import Rotation

    m, n = 4, 7
    qs = Rotation.random(m * n * sk.J, random_state=rng).as_quat().reshape(m, n, sk.J, 4)
    qs[1] *= -1.0  # same rotations, other hemisphere
    ws = rng.random((m, n))
    a = np.empty((n, sk.J, 4))
    b = np.empty((n, sk.J, 4))
    ps.blend_many(qs, ws, a)
    perm = rng.permutation(m)
    ps.blend_many(np.ascontiguousarray(qs[perm]), np.ascontiguousarray(ws[perm]), b)
    assert np.allclose(a, b, atol=1e-12)
    # two-input node: (p, s, w) equals (s, p, 1 - w)
    p1, s1 = qs[0].copy(), qs[1].copy()
    p2, s2 = qs[1].copy(), qs[0].copy()
    w = rng.random(n)
    mask = np.ones(sk.J, np.bool_)
    z = np.zeros((n, 3))
    ps.blend_kernel(p1, z.copy(), s1, z.copy(), w, mask, False)
    ps.blend_kernel(p2, z.copy(), s2, z.copy(), 1.0 - w, mask, False)
    assert np.allclose(p1, p2, atol=1e-12)


def test_default_order_by_specificity_and_override() -> None:
    chs = default_choreographers()
    order = order_by_specificity(chs)
    assert order[0] == "locomotion" and order[1] == "sitting" and order[2] == "gesture"
    assert order.index("gesture") < order.index("reach") and order.index("gesture") < order.index("gaze")
    # the body overrides the tie-prone tail with ADAPT Fig. 3's order: reach sees the gazed thorax
    assert bodies(1).coordinator.order[-2:] == ["gaze", "reach"]
    spec = {c.name: c.specificity for c in chs}
    assert spec["locomotion"] == pytest.approx(8 / 26)
    co = Coordinator(chs, order=list(reversed(order)))
    assert co.order == list(reversed(order))
    with pytest.raises(UsageError, match="must name each of"):
        Coordinator(chs, order=["locomotion"])


def test_weights_are_smoothed_over_half_a_second() -> None:
    co = Coordinator(default_choreographers())
    co.append(1)
    co.set_target("gesture", 1.0)
    for _ in range(22):
        co.smooth(1 / 90)
    assert 0.4 < co.weights[0, co.index["gesture"]] < 0.6
    for _ in range(30):
        co.smooth(1 / 90)
    assert co.weights[0, co.index["gesture"]] == 1.0


def test_capabilities_report_status() -> None:
    b = bodies(3)
    g = b.gesture(0, "wave", duration=1.0)
    r_ok = b.reach_for(1, (0.35, 1.1, 0.3), side="right")  # facing 3D +X, the right is +Z
    gz = b.gaze_at(0, (3.0, 1.6, 2.0))
    far = b.reach_for(0, (5.0, 1.0, 0.0), side="left")
    sit = b.sit_down(2)
    drive(b, lambda t: np.zeros((3, 2)), lambda t: np.zeros(3), 2.5)
    assert g.status is Status.SUCCESS
    assert r_ok.status is Status.SUCCESS, r_ok
    assert far.status is Status.FAILURE and "out of reach" in far.detail
    assert gz.status is Status.SUCCESS
    assert sit.status is Status.SUCCESS
    assert b.state.world_pos[2, sk.PELVIS, 1] < 0.7
    stop = b.gaze_at(0, None)
    assert stop.status is Status.SUCCESS
    with pytest.raises(UsageError, match="gesture 'juggle': unknown"):
        b.gesture(0, "juggle")
    nav = b.go_to(0, (1.0, 0.0))
    assert nav.status is Status.FAILURE and nav.detail == "no navigator"
    b.keep(np.array([False, True, True]))
    assert all(h.agent != 0 for h in b.handles)


def test_a_gesture_moves_only_its_own_joints_the_walk_goes_on_elsewhere() -> None:
    """A wave takes the right arm and the head; the left arm keeps swinging and the torso keeps
    its walking style exactly as without the wave."""
    from pedvr.body import skeleton as sk
    from tests.body._walk import bodies, drive

    walking, waving = bodies(1, seed=3), bodies(1, seed=3)
    waving.gesture(0, "wave", duration=3.0)
    poses = []
    for b in (walking, waving):
        seen: list[np.ndarray] = []
        drive(b, lambda t: np.array([[1.3, 0.0]]), lambda t: np.array([0.0]), 1.2,
              record=lambda body, t, seen=seen: seen.append(body.state.local_q[0].copy()))
        poses.append(np.array(seen))
    walk, wave = poses
    kept = [sk.L_COLLAR, sk.L_SHOULDER, sk.L_ELBOW, sk.L_WRIST, sk.SPINE1, sk.SPINE2, sk.SPINE3, sk.NECK]
    np.testing.assert_allclose(wave[:, kept], walk[:, kept], atol=1e-12)
    # The left arm really swings meanwhile, and the right arm is the wave's.
    assert np.ptp(walk[:, sk.L_SHOULDER, 0]) > 0.05
    assert np.abs(wave[-1, sk.R_SHOULDER] - walk[-1, sk.R_SHOULDER]).max() > 0.2
