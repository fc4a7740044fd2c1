"""A short reposition in side steps (PLACE §5: "short-range repositioning in 2-4 steps"): the lead
foot steps out, the trailing one closes, and a body that stops ends on its closing step, standing
with its feet between hip and shoulder width apart (``STANCE_MAX``) rather than squaring them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body import skeleton as sk
from pedvr.body.locomotion import MAX_WIDTH, RESTEP_DIST, STANCE_MAX, stance_err
from pedvr.demonstrator.coordination import BRAKE
from pedvr.demonstrator.demonstration import ARRIVE, REPOSITION_SPEED
from tests.body._walk import DT, Trace, bodies, drive


@pytest.mark.parametrize("dist,side", [(0.3, 1.0), (0.45, -1.0), (0.6, 1.0), (0.6, -1.0)])
def test_a_short_side_reposition_takes_two_to_four_steps(dist: float, side: float) -> None:
    b = bodies(1)
    tr = Trace()
    vmax = REPOSITION_SPEED * 0.8  # the demonstrator's reposition pace for a 0.8 m/s walker
    moved, stopped = [0.0], [False]

    def v(t: float) -> np.ndarray:
        # as pedvr.demonstrator drives it: speeding up at 1.5 m/s², braking at BRAKE toward the goal,
        # and stopped at once when within ARRIVE of it
        left = dist - moved[0]
        if stopped[0] or left < ARRIVE:
            stopped[0] = True
            return np.zeros((1, 2))
        s = min(vmax, math.sqrt(2.0 * BRAKE * max(left - 0.5 * ARRIVE, 0.0)), 1.5 * (t + DT))
        moved[0] += s * DT
        return np.array([[0.0, side * s]])

    drive(b, v, lambda t: np.zeros(1), 4.0, record=tr)
    a = tr.arrays()
    lifts = int(sum(np.count_nonzero(np.diff(a["planted"][:, 0, f].astype(int)) == -1) for f in range(2)))
    assert 2 <= lifts <= 4, lifts
    lateral = a["feet"][:, 0, :, 1]  # heading 0: sideways is 2D y
    assert np.abs(lateral[:, 0] - lateral[:, 1]).max() <= MAX_WIDTH + 0.01  # the lead steps out <= 0.42 m
    st = b.state
    assert not st.stepping[0]
    fr, root = st.foot_ref[0], st.root[0]
    assert abs(fr[0, 0] - fr[1, 0]) < 0.25 * RESTEP_DIST  # abreast of each other
    # each foot stands within the standing tolerance of the stance band beside the root (the left foot to
    # the left, the right to the right, between hip and shoulder width apart): nothing left to square
    for f in range(2):
        assert stance_err(fr[f, 0], fr[f, 1], root[0], root[1], 0.0, f, st.half_width[0],
                          st.dims[0, sk.DIM_SCALE]) <= RESTEP_DIST
    assert fr[1, 1] - fr[0, 1] <= STANCE_MAX + RESTEP_DIST  # heading 0: the body's left is 2D -y
