"""The body carries (issue 14, Huang & Terzopoulos §4.6): both hands on a box or a pram's handle,
following the body, no arm swing; a hand the behaviour takes leaves the carry and comes back."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.body import FullBody, carry
from pedvr.body import skeleton as sk
from pedvr.crowd.state import CrowdState


def _walk(kind: str, *, seconds: float, speed: float = 1.2, reach: tuple[float, float, float] | None = None,
          release_at: float | None = None) -> tuple[FullBody, np.ndarray]:
    """One body walking along +x carrying ``kind``; returns it and the hands' positions in its own
    frame (forward, up, left) at every step ``(S, 2, 3)``. ``reach`` puts the right hand on a point
    from the start (released at ``release_at``)."""
    body = FullBody(rng=np.random.default_rng(5))
    body.append(1, ids=np.array([7]), pos=np.zeros((1, 2)), heading=np.zeros(1), is_user=False,
                dims=sk.user_dims(1), carrying=kind)
    if reach is not None:
        body.reach_for(7, reach, side="right")
    v = np.array([[speed, 0.0]])
    crowd = CrowdState(ids=np.array([7]), pos=np.zeros((1, 2)), vel=np.zeros((1, 2)), pref_vel=np.zeros((1, 2)),
                       heading=np.zeros(1), pref_heading=np.zeros(1), radius=np.full(1, 0.3),
                       pref_speed=np.full(1, 1.3), max_speed=np.full(1, 1.6), responsibility=np.full(1, 0.5),
                       is_user=np.zeros(1, np.bool_), limits=np.zeros((1, 6)))
    dt, t, out = 1.0 / 90.0, 0.0, []
    for _ in range(round(seconds / dt)):
        root = crowd.pos + v * dt
        t += dt
        if release_at is not None and t >= release_at and body.state.reach_on[0, 1]:
            body.reach_for(7, None, side="right")
        body.compose(crowd, root, np.zeros(1), dt=dt, t=t, coupled=True)
        crowd.pos, crowd.vel = root, v
        hands = body.state.world_pos[0, [sk.L_HAND, sk.R_HAND]]
        out.append(np.stack([hands[:, 0] - root[0, 0], hands[:, 1], -hands[:, 2] + root[0, 1]], axis=1))
    return body, np.asarray(out)


@pytest.mark.parametrize("kind", ["box", "perambulator"])
def test_both_hands_stay_on_what_is_carried_while_walking(kind: str) -> None:
    body, hands = _walk(kind, seconds=3.0)
    want = carry.hand_targets(np.array([carry.KINDS[kind]]), np.zeros((1, 2)), np.zeros(1), np.ones(1))[0]
    local = np.stack([want[:, 0], want[:, 1], -want[:, 2]], axis=1)
    settled = hands[3:]  # from the first steps on (the first FK is a step late): it starts out holding
    assert body.state.stepping[0] or body.state.phase[0] > 0  # it is walking
    # Both hands on the box's sides / the handle's ends at every step, to within 1 mm: no arm
    # swing, and no sag as the knees bend starting the walk (the arms are solved again after the
    # legs' IK lowers the pelvis; they rode up to 4.5 cm low before).
    assert np.abs(settled - local).max() < 0.001
    # Left hand on the left, right on the right, the object's width apart.
    width = carry.BOX_SIZE[2] if kind == "box" else carry.PRAM_HANDLE_WIDTH
    assert np.allclose(settled[:, 0, 2] - settled[:, 1, 2], width, atol=0.01)


def test_an_empty_handed_walker_swings_its_arms() -> None:
    _, hands = _walk("none", seconds=3.0)
    assert np.ptp(hands[90:, :, 0], axis=0).min() > 0.08  # the hands swing back and forth


def test_a_hand_taken_by_the_behaviour_leaves_the_box_and_returns() -> None:
    """§4.6's carrier who frees a hand (after waiting alone at a pull side) reaches with it; the
    other hand stays on the box, and the freed one comes back when released."""
    point = (0.40, 1.05, 0.30)  # 3D world (left is -z): ahead and to the right of the start, at handle height
    body, hands = _walk("box", seconds=2.0, speed=0.0, reach=point, release_at=1.0)
    assert np.linalg.norm(body.state.world_pos[0, sk.R_HAND] - carry.hand_targets(
        np.array([carry.BOX]), body.state.root, body.state.heading, np.ones(1))[0, 1]) < 0.01
    body2, hands2 = _walk("box", seconds=1.0, speed=0.0, reach=point)
    assert np.linalg.norm(body2.state.world_pos[0, sk.R_HAND] - np.asarray(point)) < 0.01
    want = carry.hand_targets(np.array([carry.BOX]), np.zeros((1, 2)), np.zeros(1), np.ones(1))[0]
    assert np.linalg.norm(body2.state.world_pos[0, sk.L_HAND] - want[0]) < 0.01
