"""Gaze controller limits, speed caps, eyes-lead, frame-rate independence; the PedVR gaze rule."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.body import pose as ps
from pedvr.body import skeleton as sk
from pedvr.body.model import FullBody
from pedvr.scene.config import Obstacle, WorldConfig
from pedvr.world import Visibility
from tests.body._walk import crowd_of


def _run_gaze(targets: list[np.ndarray], dt: float, *, running: bool = False) -> np.ndarray:
    """Controller state (steps, 5, 2) for one body at the origin facing 2D +x (3D +X)."""
    n = 1
    ang = np.zeros((n, 5, 2))
    q = np.zeros((n, sk.J, 4))
    q[..., 3] = 1.0
    out = q.copy()
    head = np.array([[0.0, 1.6, 0.0]])
    yaw = np.array([0.5 * np.pi])
    hist = []
    for tgt in targets:
        ps.gaze_kernel(dt, np.array([tgt is not None]), np.zeros((1, 3)) if tgt is None else tgt[None], head,
                       yaw, np.array([running]), ps.GAZE_SHARE, ps.GAZE_YAW_LIMIT, ps.GAZE_PITCH_LIMIT,
                       ps.GAZE_SPEED, ps.GAZE_TAU, ang, q, out, np.zeros((1, 3)), np.zeros((1, 3)),
                       np.array([[0.0, 0.0, 0.0, 1.0]]), np.array([False]))
        hist.append(ang[0].copy())
    return np.array(hist)


def _jumping_targets(dt: float, seconds: float, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    tgt = None
    for k in range(round(seconds / dt)):
        if k % round(0.7 / dt) == 0:
            a = rng.uniform(-np.pi, np.pi)
            tgt = np.array([3 * np.cos(a), rng.uniform(0.0, 3.0), 3 * np.sin(a)]) if rng.random() > 0.2 else None
        out.append(tgt)
    return out


def test_limits_and_speed_caps_never_exceeded() -> None:
    dt = 1.0 / 90.0
    h = _run_gaze(_jumping_targets(dt, 30.0), dt)
    eps = 1e-9
    for k in range(5):
        assert np.abs(h[:, k, 0]).max() <= ps.GAZE_YAW_LIMIT[k] + eps
        assert np.abs(h[:, k, 1]).max() <= ps.GAZE_PITCH_LIMIT[k] + eps
        rate = np.abs(np.diff(h[:, k], axis=0)) / dt
        assert rate.max() <= ps.GAZE_SPEED[k] + 1e-6
    head_on_trunk = np.abs(h[:, 2, 0] + h[:, 3, 0])
    assert head_on_trunk.max() <= np.radians(80.0) + eps
    assert np.abs(h[:, 4, 0]).max() <= np.radians(35.0) + eps
    head_speed = np.abs(np.diff(h[:, 2, 0] + h[:, 3, 0])) / dt
    assert head_speed.max() <= np.radians(300.0) + 1e-6


def test_eyes_lead_head_catches_up_and_reaches_target() -> None:
    dt = 1.0 / 90.0
    tgt = np.array([3 * np.cos(1.0), 1.6, 3 * np.sin(1.0)])  # 3D: ~57° to the body's left? check sign below
    h = _run_gaze([tgt] * round(2.0 / dt), dt)
    total = h[:, :, 0].sum(axis=1)
    k10 = round(0.1 / dt)
    assert abs(h[k10, 4, 0]) > abs(h[k10, 3, 0])  # eyes ahead of the head at 0.1 s
    goal = total[-1]
    assert abs(abs(goal) - abs(np.arctan2(tgt[0], tgt[2]) - 0.0)) < np.radians(60)  # sanity
    assert abs(h[-1, 4, 0]) < abs(h[k10, 4, 0])  # eyes recentre as the head arrives


def test_frame_rate_independent() -> None:
    tgt = np.array([0.0, 1.6, 3.0])
    a = _run_gaze([tgt] * 90, 1.0 / 90.0)
    b = _run_gaze([tgt] * 30, 1.0 / 30.0)
    # compare at the same times (1/3 s, 2/3 s, 1 s)
    for ka, kb in ((29, 9), (59, 19), (89, 29)):
        assert np.abs(a[ka] - b[kb]).max() < np.radians(4.0)


def test_running_message_restricts_the_torso() -> None:
    tgt = np.array([-3.0, 1.6, 0.5])
    walk = _run_gaze([tgt] * 180, 1 / 90)
    run = _run_gaze([tgt] * 180, 1 / 90, running=True)
    assert abs(run[-1, 0, 0]) < abs(walk[-1, 0, 0])


# ---- the PedVR rule -------------------------------------------------------------------------------

WALL = Obstacle(vertices=((-0.5, -3.0), (0.5, -3.0), (0.5, -1.0), (-0.5, -1.0)))


@pytest.fixture(scope="module")
def vis() -> Visibility:
    return Visibility(WorldConfig(bounds=((-20.0, -20.0), (20.0, 20.0)), obstacles=(WALL,)))


def _rule(body: FullBody, vis: Visibility, p_user, v_user, p_agent, v_agent, heading, t: float,
          enabled: bool = True):
    crowd = crowd_of(2, pos=np.array([p_user, p_agent]), heading=np.array([0.0, heading]), user=0)
    crowd.vel = np.array([v_user, v_agent], np.float64)
    return body.gaze_rule(crowd, t=t, visibility=vis, d1=4.0, d2=2.0, enabled=enabled)


def test_rule_switches_on_and_off_on_a_scripted_approach(vis: Visibility) -> None:
    b = FullBody(rng=np.random.default_rng(0))
    b.append(1, ids=[0], pos=[[0, 0]], heading=[0], is_user=True)
    b.append(1, ids=[1], pos=[[0, 5]], heading=[0], is_user=False)
    events = []
    # the user walks toward the agent (standing at (0, 5) facing -y) along x = 0, then past it
    dt = 0.1
    for k in range(120):
        t = k * dt
        pu = (0.0, -2.0 + 1.2 * t) if t < 8 else (0.0, 7.6 + 1.2 * (t - 8))
        pu = (0.3, pu[1])
        events += _rule(b, vis, pu, (0.0, 1.2), (0.0, 5.0), (0.0, 0.0), -np.pi / 2, t)
    starts = [e for e in events if e["event"] == "start"]
    ends = [e for e in events if e["event"] == "end"]
    assert len(starts) == 1 and len(ends) == 1
    assert starts[0]["agent"] == 1 and starts[0]["target"] == "user"
    # starts when the user is within D1 = 4 m: at y = 1.0 -> t = 2.5 s
    assert abs(float(starts[0]["t"]) - 2.5) <= 0.11
    assert float(ends[0]["t"]) > float(starts[0]["t"])


def test_rule_conditions(vis: Visibility) -> None:
    b = FullBody(rng=np.random.default_rng(0))
    b.append(1, ids=[0], pos=[[0, 0]], heading=[0], is_user=True)
    b.append(1, ids=[1], pos=[[0, 3]], heading=[0], is_user=False)
    # approaching, within D1, facing the user: on
    assert _rule(b, vis, (0.2, 0.5), (0, 1.0), (0, 3), (0, 0), -np.pi / 2, 0.0)[0]["event"] == "start"
    # receding (w < 0): off
    assert _rule(b, vis, (0.2, 0.5), (0, -1.0), (0, 3), (0, 0), -np.pi / 2, 0.1)[0]["event"] == "end"
    # closing faster than D2: stays off
    assert _rule(b, vis, (0.2, 0.5), (0, 2.5), (0, 3), (0, 0), -np.pi / 2, 0.2) == []
    # behind the agent (outside its field of view): off
    assert _rule(b, vis, (0.2, 0.5), (0, 1.0), (0, 3), (0, 0), np.pi / 2, 0.3) == []
    # occluded by the wall between them: off
    assert _rule(b, vis, (0.0, -4.0), (0, 1.0), (0, 0.0), (0, 0), -np.pi / 2, 0.4) == []
    # disabled (conditions PedVR and Decoupled): off
    assert _rule(b, vis, (0.2, 0.5), (0, 1.0), (0, 3), (0, 0), -np.pi / 2, 0.5, enabled=False) == []


def test_gaze_rule_turns_the_head_toward_the_user() -> None:
    from pedvr.scene.loader import load_scene
    from pedvr.scenes import resolve_scene
    from pedvr.sim import Simulation

    sim = Simulation(load_scene(resolve_scene("headon_corridor")), condition="pedvr+g")
    sim.advance_to(6.0)
    ev = sim.summary()["gaze_events"]
    assert any(e["event"] == "start" for e in ev), ev
    off = Simulation(load_scene(resolve_scene("headon_corridor")), condition="pedvr")
    off.advance_to(6.0)
    assert off.summary()["gaze_events"] == []


def _eye_errors_deg(body: FullBody, target: np.ndarray) -> tuple[float, float]:
    """Angle between each eye's forward (+Z) and its own line to ``target``."""
    from scipy.spatial.transform import Rotation

    out = []
    for j in (sk.L_EYE, sk.R_EYE):
        fwd = Rotation.from_quat(body.state.world_q[0, j]).apply([0.0, 0.0, 1.0])
        d = target - body.state.world_pos[0, j]
        out.append(float(np.degrees(np.arccos(np.clip(fwd @ d / np.linalg.norm(d), -1.0, 1.0)))))
    return out[0], out[1]


@pytest.mark.parametrize("lateral", [0.0, 1.5])
def test_walking_eyes_stay_on_the_target_and_converge(lateral: float) -> None:
    """The eyes cancel the walk's head bob and sway (closed loop on the head, like the
    vestibulo-ocular reflex) and each eye looks at the target itself, so a participant
    at the target sees both pupils on them; the head need not point exactly."""
    from tests.body._walk import bodies, drive

    body = bodies(1)
    target = np.array([5.0, 1.6, lateral])  # a standing person's eyes, ahead (3D x, y up, z)
    body.gaze_at(0, tuple(target))
    errs: list[tuple[float, float]] = []
    drive(body, lambda t: np.array([[1.3, 0.0]]), lambda t: np.array([0.0]), 2.0,
          record=lambda b, t: errs.append(_eye_errors_deg(b, target)) if t > 0.5 else None)
    assert max(max(e) for e in errs) < 1.5
    # Vergence: the two eyes do not point in parallel at a target 5 m away.
    from scipy.spatial.transform import Rotation

    fl, fr = (Rotation.from_quat(body.state.world_q[0, j]).apply([0.0, 0.0, 1.0]) for j in (sk.L_EYE, sk.R_EYE))
    assert np.degrees(np.arccos(np.clip(fl @ fr, -1, 1))) > 0.3
