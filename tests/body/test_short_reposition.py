"""A short reposition in side steps (PLACE §5: "short-range repositioning in 2-4 steps"): the lead
foot steps out at most MAX_WIDTH, the trailing one closes, and a body that stops ends on its closing
step, squared or in a wide stance abreast of the lead foot, rather than squaring its feet with a
further step. A forward stop still squares them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body.locomotion import MAX_WIDTH, RESTEP_DIST, STANCE_MAX, stand_ref
from pedvr.demonstrator.coordination import BRAKE
from pedvr.demonstrator.demonstration import ARRIVE, REPOSITION_SPEED
from tests.body._walk import DT, Trace, bodies, drive


def _reposition(direction: tuple[float, float], dist: float) -> tuple[Trace, object]:
    """One body facing +x moved ``dist`` m along ``direction`` as pedvr.demonstrator drives a short
    reposition: speeding up at 1.5 m/s² to its reposition pace, braking at BRAKE toward the goal and
    stopped at once within ARRIVE of it; then left standing for 2 s."""
    b = bodies(1)
    tr = Trace()
    u = np.asarray(direction, np.float64) / math.hypot(*direction)
    vmax = REPOSITION_SPEED * 0.8  # the demonstrator's pace for a 0.8 m/s walker
    moved, stopped = [0.0], [False]

    def v(t: float) -> np.ndarray:
        left = dist - moved[0]
        if stopped[0] or left < ARRIVE:
            stopped[0] = True
            return np.zeros((1, 2))
        s = min(vmax, math.sqrt(2.0 * BRAKE * max(left - 0.5 * ARRIVE, 0.0)), 1.5 * (t + DT))
        moved[0] += s * DT
        return (s * u)[None]

    drive(b, v, lambda t: np.zeros(1), 5.0, record=tr)
    return tr, b


def _lifts(planted: np.ndarray) -> int:
    return int(sum(np.count_nonzero(np.diff(planted[:, f].astype(int)) == -1) for f in range(2)))


# heading 0: the body's left is 2D -y, its back -x
@pytest.mark.parametrize("dist", [0.3, 0.45, 0.6])
@pytest.mark.parametrize("direction", [(0.0, -1.0), (0.0, 1.0), (-0.55, 0.84)], ids=["left", "right", "back_right"])
def test_a_short_side_reposition_takes_two_to_four_steps(direction: tuple[float, float], dist: float) -> None:
    tr, b = _reposition(direction, dist)
    a = tr.arrays()
    lifts = _lifts(a["planted"][:, 0])
    assert 2 <= lifts <= 4, lifts
    feet = a["feet"][:, 0]
    assert np.abs(feet[:, 0, 1] - feet[:, 1, 1]).max() <= MAX_WIDTH + 1e-9  # the lead steps out at most MAX_WIDTH
    assert np.hypot(*tr.swings(0).T).max() <= 0.45  # and no foot moves more than 0.45 m (people's side steps)
    st = b.state
    assert not st.stepping[0] and a["planted"][-round(2.0 / DT):].all()  # standing still for the last 2 s
    fr, root, hw = st.foot_ref[0], st.root[0], st.half_width[0]
    # heading 0: a foot's own side is -y for the left foot, +y for the right; ahead is +x
    w = np.array([root[1] - fr[0, 1], fr[1, 1] - root[1]])
    lon = fr[:, 0] - root[0]
    square = all(math.dist(fr[f], stand_ref(root[0], root[1], 0.0, f, hw)) < 0.5 * RESTEP_DIST for f in range(2))
    # or a wide stance: abreast, the root midway, wider than the hip and at most STANCE_MAX apart
    wide = (abs(lon[0] - lon[1]) < 0.25 * RESTEP_DIST and abs(w[0] - w[1]) < 0.25 * RESTEP_DIST
            and w.min() > hw and w.sum() <= STANCE_MAX + 1e-9 and abs(lon).max() < RESTEP_DIST)
    assert square or wide, (w, lon)


def test_a_forward_stop_squares_the_feet() -> None:
    """Walking forward and stopping as the demonstrator brakes: the feet end beside the root, hip
    width apart (the closing step lands on its spot; the abreast closing is for side steps only)."""
    tr, b = _reposition((1.0, 0.0), 1.5)
    st = b.state
    assert not st.stepping[0]
    fr, root, hw = st.foot_ref[0], st.root[0], st.half_width[0]
    for f in range(2):
        assert math.dist(fr[f], stand_ref(root[0], root[1], 0.0, f, hw)) <= 0.5 * RESTEP_DIST
