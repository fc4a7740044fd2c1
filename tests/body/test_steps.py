"""App. C.2's step generator (Huang & Terzopoulos Fig. 20): first step by α, the C_s1 / C_s2
limits, the last step and the standing end, the auxiliary turning step, backward steps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body.steps import (
    ALPHA_STANDING,
    ALPHA_WALKING,
    C_S1,
    C_S2,
    L_STEP,
    LEFT,
    RIGHT,
    W_STEP,
    generate_steps,
)

FEET = {"left": np.array([0.0, 0.1]), "right": np.array([0.0, -0.1])}


@pytest.mark.parametrize("standing, alpha", [(True, ALPHA_STANDING), (False, ALPHA_WALKING)])
def test_first_step_is_alpha_step_lengths_ahead(standing: bool, alpha: float) -> None:
    plan = generate_steps(root=np.zeros(2), **FEET, swing=RIGHT, standing=standing, target=np.array([3.0, 0.0]),
                          end_standing=False)
    first = plan.steps[0]
    assert first.side == RIGHT
    want = np.array([alpha * L_STEP, -W_STEP])
    if np.linalg.norm(want - FEET["left"]) > C_S1:  # eq. 2 keeps it within C_s1 of the other foot
        assert np.linalg.norm(first.pos - FEET["left"]) == pytest.approx(C_S1)
    else:
        np.testing.assert_allclose(first.pos, want)


def test_steps_alternate_and_respect_the_limits() -> None:
    plan = generate_steps(root=np.zeros(2), **FEET, swing=LEFT, standing=True, target=np.array([2.0, 0.7]),
                          target_facing=0.3)
    feet = {LEFT: FEET["left"], RIGHT: FEET["right"]}
    for a, b in zip(plan.steps, plan.steps[1:], strict=False):
        assert a.side != b.side  # feet alternate
    for st in plan.steps:
        assert np.linalg.norm(st.pos - feet[st.side]) <= C_S2 + 1e-9  # eq. 5
        feet[st.side] = st.pos
    # It ends standing, the feet W_step either side of the target, square to the target facing.
    last_two = plan.steps[-2:]
    mid = 0.5 * (last_two[0].pos + last_two[1].pos)
    np.testing.assert_allclose(mid, [2.0, 0.7], atol=1e-12)
    left = next(s.pos for s in last_two if s.side == LEFT)
    right_dir = np.array([math.sin(0.3), -math.cos(0.3)])
    np.testing.assert_allclose(left, np.array([2.0, 0.7]) - right_dir * W_STEP, atol=1e-12)
    # Root keys: from the root to the target, ending in the target facing.
    np.testing.assert_allclose(plan.root[0], [0.0, 0.0])
    np.testing.assert_allclose(plan.root[-1], [2.0, 0.7], atol=1e-12)
    assert plan.facing[-1] == pytest.approx(0.3)


def test_side_step_toward_the_supporting_foot_takes_an_auxiliary_step() -> None:
    """Fig. 20c: stepping left while the right foot swings would cross over the left foot."""
    plan = generate_steps(root=np.zeros(2), **FEET, swing=RIGHT, standing=True, target=np.array([0.0, 0.8]),
                          target_facing=0.0)
    assert plan.auxiliary
    # The auxiliary step puts the right foot beside the left one, not across it.
    assert plan.steps[0].side == RIGHT
    no_aux = generate_steps(root=np.zeros(2), **FEET, swing=LEFT, standing=True, target=np.array([0.0, 0.8]),
                            target_facing=0.0)
    assert not no_aux.auxiliary and no_aux.steps[0].side == LEFT


def test_backward_steps_face_away_from_the_travel() -> None:
    plan = generate_steps(root=np.zeros(2), **FEET, swing=LEFT, standing=True, target=np.array([-0.9, 0.0]),
                          backward=True)
    assert all(abs(math.cos(f)) == pytest.approx(1.0) and math.cos(f) > 0 for f in plan.facing)
    assert plan.root[-1][0] == pytest.approx(-0.9)
