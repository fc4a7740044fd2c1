"""Footstep walking: bands, pinned feet, start/stop, turning on the spot, sidestep, step back.

Planted feet are measured by the skate meter from the first frame a heel or toe tip is within
2 mm of the floor, so the last instant of a heel's descent counts; ``PINNED`` allows that much.
"""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.body import FullBody
from pedvr.body import skeleton as sk
from pedvr.body.locomotion import LEFT
from tests.body._walk import bodies, drive

HEIGHTS = np.array([1.55, 1.65, 1.75, 1.85, 1.95])
PINNED = 0.001  # m


@pytest.fixture(scope="module")
def straight() -> dict[float, FullBody]:
    """Five heights walking straight at each test speed for 12 s."""
    out = {}
    for v in (1.3, 1.35, 1.4):
        b = bodies(len(HEIGHTS), heights=HEIGHTS)
        drive(b, lambda t, v=v: np.tile([v, 0.0], (5, 1)), lambda t: np.zeros(5), 12.0)
        out[v] = b
    return out


def _steady_steps(b: FullBody) -> np.ndarray:
    st = np.concatenate(b.step_log)
    return st[st[:, 1] < 1.5][10:]  # after the start


def test_cadence_and_step_length_bands(straight: dict[float, FullBody]) -> None:
    for v, b in straight.items():
        st = np.concatenate(b.step_log)
        for row in range(len(HEIGHTS)):
            mine = st[(st[:, 0] == row) & (st[:, 1] < 1.5)][6:]
            cadence = 1.0 / mine[:, 1].mean()
            length = mine[:, 2].mean()
            assert 1.8 <= cadence <= 2.1, (v, HEIGHTS[row], cadence)
            assert 0.65 <= length <= 0.78, (v, HEIGHTS[row], length)


def test_planted_feet_do_not_slide_when_walking(straight: dict[float, FullBody]) -> None:
    for b in straight.values():
        s = b.skate.slides()
        assert s.size > 50
        assert s.max() < PINNED


def test_start_stop_returns_to_standing() -> None:
    b = bodies(1)
    def speed(t):
        return np.array([[1.3 * min(1.0, t / 1.0) if t < 4.0 else max(0.0, 1.3 - 2.0 * (t - 4.0)), 0.0]])
    drive(b, speed, lambda t: np.zeros(1), 7.0)
    st = b.state
    assert not st.stepping[0]
    assert b.skate.slides().max() < PINNED
    # feet beside each other under the root, hip width apart
    fr = st.foot_ref[0]
    assert abs(fr[0, 0] - fr[1, 0]) < 0.1
    assert abs(np.linalg.norm(fr[0] - fr[1]) - 2 * st.half_width[0]) < 0.05
    assert abs(st.world_pos[0, sk.PELVIS, 1] - st.pelvis_rest[0]) < 0.05


def test_turn_on_the_spot_steps_the_feet_round() -> None:
    b = bodies(1)
    steps = []
    drive(b, lambda t: np.zeros((1, 2)), lambda t: np.array([min(np.pi / 2, 1.5 * t)]), 4.0,
          record=lambda bb, t: steps.append(bb.state.stepping[0]))
    st = b.state
    assert any(steps)
    for f in range(2):
        assert abs((st.foot_yaw[0, f] - np.pi / 2 + np.pi) % (2 * np.pi) - np.pi) < 0.25
    assert b.skate.slides().max() < PINNED
    assert np.linalg.norm(st.root[0]) < 1e-9


@pytest.mark.parametrize("direction", ["left", "right", "back"])
def test_sidestep_and_step_back_without_crossing(direction: str) -> None:
    # heading 0: anatomical left is the 2D direction -y
    v = {"left": (0.0, -0.5), "right": (0.0, 0.5), "back": (-0.45, 0.0)}[direction]
    b = bodies(1)
    gaps = []

    def rec(bb: FullBody, t: float) -> None:
        fr = bb.state.foot_ref[0]
        gaps.append((fr[LEFT] - fr[1 - LEFT]) @ np.array([0.0, -1.0]))  # left foot's lead to the left

    drive(b, lambda t: np.array([v]) if t < 3.0 else np.zeros((1, 2)), lambda t: np.zeros(1), 5.0, record=rec)
    assert min(gaps) > 0.05  # never crossed over
    moved = b.state.root[0]
    assert np.linalg.norm(moved - 3.0 * np.array(v)) < 0.01
    assert b.skate.slides().max() < PINNED
    # the feet followed the body
    assert np.linalg.norm(b.state.foot_ref[0].mean(axis=0) - moved) < 0.15


def test_speed_change_within_a_stride() -> None:
    b = bodies(1)
    def v(t):
        return np.array([[0.6 + 0.8 * (np.sin(2.3 * t) > 0), 0.0]])  # jumps every ~1.4 s
    drive(b, v, lambda t: np.zeros(1), 8.0)
    assert b.skate.slides().max() < PINNED


def test_decoupled_cycle_skates_when_turning_and_slow() -> None:
    b = bodies(1)
    # a slow curve: the clamped playback rate and the turning both drag the planted feet
    drive(b, lambda t: np.array([[0.45 * np.cos(0.8 * t), 0.45 * np.sin(0.8 * t)]]),
          lambda t: np.array([0.8 * t]), 8.0, coupled=False)
    assert b.skate.slides().max() > 0.02
