"""Door mechanics (Huang & Terzopoulos App. A): leaves open away from walkers, never cut
into them, bounce on release and close; the App. A control functions invert each other."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.etiquette.doors import (
    BOUNCE_ANGLE,
    CLOSED,
    CLOSING,
    HAND_SPEED,
    HELD,
    MAX_ANGLE,
    PASSAGE_ANGLE,
    DoorLeaves,
    hand_angle,
    hand_point,
)
from pedvr.scene.config import Door, WorldConfig

DT = 1 / 90
R = 0.25


def _leaves(kind: str = "single", width: float = 1.0, swing: str = "both_ways", pull: int = 1) -> DoorLeaves:
    """A door in the line y = 0, from x = -w/2 to x = +w/2 (the + side of its first leaf is +y)."""
    door = Door(span=((-width / 2, 0.0), (width / 2, 0.0)), kind=kind, swing=swing, pull=pull)
    return DoorLeaves.of_world(WorldConfig(bounds=((-5.0, -5.0), (5.0, 5.0)), doors=(door,)))


def _overlap(leaves: DoorLeaves, pos: np.ndarray, radius: np.ndarray) -> float:
    _, deepest = leaves.push_out(pos, radius, np.zeros(len(pos), np.bool_))
    return deepest


def _walk(leaves: DoorLeaves, start: tuple[float, float], vel: tuple[float, float], seconds: float,
          *, stop_y: float | None = None) -> list[tuple[float, np.ndarray, np.ndarray, float]]:
    """One walker at constant velocity (halting at ``stop_y``); per step (t, pos, angles, overlap)."""
    pos = np.array([start], np.float64)
    v = np.array([vel], np.float64)
    rad = np.array([R])
    out = []
    for k in range(round(seconds / DT)):
        if stop_y is not None and (pos[0, 1] - stop_y) * np.sign(v[0, 1]) >= 0:
            v[:] = 0.0
        pos = pos + v * DT
        leaves.step(DT, pos, v, rad)
        out.append(((k + 1) * DT, pos[0].copy(), leaves.angle.copy(), _overlap(leaves, pos, rad)))
    return out


def test_walker_pushes_the_leaf_away_and_it_closes_behind() -> None:
    leaves = _leaves()
    trace = _walk(leaves, (0.0, -3.0), (0.0, 1.3), 9.0, stop_y=4.0)
    angles = np.array([a[0] for _, _, a, _ in trace])
    ys = np.array([p[1] for _, p, _, _ in trace])
    # It opens toward +y, away from the walker coming from -y, and is at the passage angle
    # by the time the walker's disc reaches the doorway line.
    assert angles.min() >= 0.0
    reach = np.flatnonzero(ys >= -R)[0]
    assert angles[reach] >= math.radians(70)
    # It never cuts into the walker.
    assert max(o for *_, o in trace) <= 1e-9
    # Released, it bounces past where it was held, then the closer shuts it.
    assert angles.max() >= PASSAGE_ANGLE + 0.8 * BOUNCE_ANGLE
    assert angles.max() <= MAX_ANGLE + 1e-12
    assert angles[-1] == 0.0 and leaves.phase[0] == CLOSED and leaves.side[0] == 0


def test_walker_from_the_other_side_opens_it_the_other_way() -> None:
    leaves = _leaves()
    trace = _walk(leaves, (0.0, 3.0), (0.0, -1.3), 4.0)
    angles = np.array([a[0] for _, _, a, _ in trace])
    assert angles.max() <= 0.0 and angles.min() <= -math.radians(70)
    assert max(o for *_, o in trace) <= 1e-9


def test_someone_standing_in_the_swing_stops_the_leaf() -> None:
    """f_bounce's p_stop: a walker on the far side, inside the swing circle, stops the leaf."""
    leaves = _leaves()
    bystander = np.array([[-0.1, 0.55]])  # inside the swing circle on the +y side, not moving
    pos = np.array([[0.0, -1.2]])
    v = np.array([[0.0, 1.0]])
    for _ in range(round(0.8 / DT)):
        pos = pos + v * DT
        both = np.concatenate([pos, bystander])
        leaves.step(DT, both, np.concatenate([v, np.zeros((1, 2))]), np.array([R, R]))
        assert _overlap(leaves, both, np.array([R, R])) <= 1e-9
    assert leaves.phase[0] == HELD
    assert 0.0 < leaves.angle[0] < PASSAGE_ANGLE - math.radians(10)  # stopped short of the passage angle


def test_a_body_pushes_a_closed_leaf_open_without_a_hand() -> None:
    """A disc that drifts into the leaf (too slowly to count as opening it) pushes it aside."""
    leaves = _leaves()
    rad = np.array([R])
    still = np.zeros((1, 2))
    for k in range(60):
        pos = np.array([[0.2, -0.35 + 0.01 * k]])  # creeps through the doorway line
        leaves.step(DT, pos, still, rad)
        assert _overlap(leaves, pos, rad) <= 1e-9
    assert leaves.angle[0] > math.radians(20)


def test_double_door_leaves_both_swing_to_the_far_side() -> None:
    leaves = _leaves("double", 1.8)
    assert len(leaves) == 2
    np.testing.assert_allclose(leaves.length, [0.9, 0.9])
    trace = _walk(leaves, (0.0, -3.0), (0.0, 1.3), 2.6)
    assert max(o for *_, o in trace) <= 1e-9
    # Mirrored leaves: opposite signed angles, both tips on the walker's far side (+y).
    a0, a1 = trace[-1][2]
    assert a0 > math.radians(60) and a1 < -math.radians(60)
    assert (leaves.tips()[:, 1] > 0.5).all()


def test_leaf_at_the_stop_pushes_bodies_out_but_never_the_user() -> None:
    leaves = _leaves()
    leaves.angle[:] = MAX_ANGLE
    tip_dir = np.array([math.cos(MAX_ANGLE), math.sin(MAX_ANGLE)])
    on_leaf = leaves.hinge[0] + 0.5 * tip_dir + 0.1 * np.array([tip_dir[1], -tip_dir[0]])
    pos = np.array([on_leaf, on_leaf])
    out, deepest = leaves.push_out(pos, np.array([R, R]), np.array([True, False]))
    np.testing.assert_allclose(out[1], on_leaf)  # the user (not movable) stays
    assert deepest == pytest.approx(R - 0.1)
    # The moved disc now just touches the leaf.
    rest = DoorLeaves.push_out(leaves, out[:1], np.array([R]), np.array([False]))[1]
    assert rest <= 1e-9


def test_app_a_control_functions_invert_each_other() -> None:
    hinge, base = np.array([1.0, 2.0]), math.radians(30)
    for angle in np.radians([-95.0, -40.0, 0.0, 25.0, 80.0]):
        for p_rel in (0.3, 0.85):
            p = hand_point(hinge, base, float(angle), p_rel)
            assert np.hypot(*(p - hinge)) == pytest.approx(p_rel)
            assert hand_angle(hinge, base, p) == pytest.approx(angle)


def test_of_world_leaves_and_pose() -> None:
    leaves = _leaves("single", 1.2)
    np.testing.assert_allclose(leaves.hinge, [[-0.6, 0.0]])
    assert leaves.base[0] == pytest.approx(0.0) and leaves.length[0] == pytest.approx(1.2)
    leaves.angle[:] = math.pi / 2
    np.testing.assert_allclose(leaves.tips(), [[-0.6, 1.2]], atol=1e-12)
    pose = leaves.pose()
    assert pose.shape == (1, 5)
    np.testing.assert_allclose(pose[0], [-0.6, 0.0, math.pi / 2, 1.2, 2.1])


def test_the_user_always_gets_through_a_leaf_pinned_by_someone_else() -> None:
    """A walker behind the leaf stops it (p_stop); the user, whom nothing can push, does not:
    the leaf gets out of the user's way and the walker is pushed aside instead."""
    leaves = _leaves()
    leaves.angle[:] = -math.radians(60)  # swung to -y, the user's far side
    leaves.side[:] = -1
    leaves.phase[:] = HELD
    tip = leaves.tips()[0]
    mid = 0.5 * (leaves.hinge[0] + tip)
    normal = np.array([-(tip - leaves.hinge[0])[1], (tip - leaves.hinge[0])[0]])
    normal /= np.linalg.norm(normal)
    walker = mid - (R + 0.001) * normal  # just clear of the leaf's other face
    user = mid + 0.8 * (R) * normal  # already 5 cm into this face
    pos = np.array([user, walker])
    rad = np.array([R, R])
    fixed = np.array([True, False])
    leaves.step(DT, pos, np.zeros((2, 2)), rad, fixed=fixed)
    out, deepest = leaves.push_out(pos, rad, ~fixed)
    np.testing.assert_allclose(out[0], user)  # the user did not move
    assert deepest <= 1e-9  # and nobody is inside the leaf any more: the walker was moved
    assert np.linalg.norm(out[1] - walker) > 0.01


# -- one-way leaves: a pull side and a push side (App. B.2) -------------------------------------------


def test_one_way_leaf_opens_only_into_its_pull_side() -> None:
    leaves = _leaves(swing="one_way", pull=1)  # pulled from +y, pushed from -y
    assert leaves.swing[0] == 1
    # Walking in from the push side pushes it open toward the pull side.
    trace = _walk(leaves, (0.0, -3.0), (0.0, 1.3), 4.0)
    assert max(a[0] for _, _, a, _ in trace) >= math.radians(70)
    assert min(a[0] for _, _, a, _ in trace) >= 0.0
    assert max(o for *_, o in trace) <= 1e-9


def test_nobody_walks_through_a_closed_one_way_leaf_from_its_pull_side() -> None:
    leaves = _leaves(swing="one_way", pull=1)
    pos = np.array([[0.1, 1.5]])
    v = np.array([[0.0, -1.3]])
    rad = np.array([R])
    for _ in range(round(2.5 / DT)):
        pos = pos + v * DT
        leaves.step(DT, pos, v, rad)
        pos, _ = leaves.push_out(pos, rad, np.array([True]))
    assert leaves.angle[0] == 0.0  # never opened: it takes a hand from this side
    assert pos[0, 1] >= R - 1e-9  # and the walker is still on its side of the closed leaf


@pytest.mark.parametrize("ajar_deg, held", [(5.0, False), (9.0, False), (40.0, True)])
def test_walking_at_a_one_way_leaf_from_its_pull_side_holds_it_only_when_open(ajar_deg: float,
                                                                            held: bool) -> None:
    """Issue 26: a leaf closing within PULL_CATCH_ANGLE is shut for one on its pull side without a
    hand (a pram walking at a leaf 1.8° from latching swung it open toward itself, round its front);
    one still open is held for whoever walks into the doorway from that side, as before."""
    leaves = _leaves(swing="one_way", pull=1)
    leaves.angle[0] = math.radians(ajar_deg)
    leaves.side[0] = 1
    leaves.phase[0] = CLOSING
    pos = np.array([[0.68, 1.6]])  # at the latch end, beyond the leaf's swing (hinge at x = -0.5)
    v = np.array([[0.0, -1.0]])
    rad = np.array([R])
    widest = leaves.angle[0]
    for _ in range(round(3.0 / DT)):
        if pos[0, 1] <= 0.5:  # it stops 0.5 m out, within a hand's reach of the doorway line
            v[:] = 0.0
        pos = pos + v * DT
        leaves.step(DT, pos, v, rad)
        widest = max(widest, leaves.angle[0])
    if held:
        assert widest >= math.radians(70.0)  # held open toward the passage angle
    else:
        assert widest <= math.radians(ajar_deg) + 1e-12  # never opened further
        assert leaves.angle[0] == 0.0  # and it latched


def test_mirrored_double_door_leaves_open_the_same_way() -> None:
    leaves = _leaves("double", 1.8, swing="one_way", pull=-1)  # pulled from -y
    assert list(leaves.swing) == [-1, 1]  # hinge at -x turns clockwise to -y, hinge at +x counter-clockwise
    trace = _walk(leaves, (0.0, 3.0), (0.0, -1.3), 2.6)  # pushed from +y
    assert max(o for *_, o in trace) <= 1e-9
    assert (leaves.tips()[:, 1] < -0.5).all()


# -- the hand (App. A): automatic opening, the hand leading, bounce with p_stop -----------------------


def test_a_hand_opens_holds_and_releases_a_leaf() -> None:
    leaves = _leaves(swing="one_way", pull=1)
    nobody = np.zeros((0, 2))
    leaves.grab(0, open_to=math.radians(90))
    for _ in range(round(1.0 / DT)):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert leaves.angle[0] == pytest.approx(math.radians(90))
    # The hand leads: the leaf follows f_a of where the hand is, at most HAND_SPEED.
    hand = hand_point(leaves.hinge[0], float(leaves.base[0]), math.radians(60), 0.9)
    leaves.hand(0, hand_angle(leaves.hinge[0], float(leaves.base[0]), hand))
    leaves.step(DT, nobody, nobody, np.zeros(0))
    assert math.radians(90) - leaves.angle[0] == pytest.approx(HAND_SPEED * DT)
    for _ in range(30):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert leaves.angle[0] == pytest.approx(math.radians(60))
    # Released with a stop at 40 degrees: it bounces, closes, halts at the stop.
    leaves.release(0, stop=math.radians(40))
    peak = 0.0
    for _ in range(round(3.0 / DT)):
        leaves.step(DT, nobody, nobody, np.zeros(0))
        peak = max(peak, leaves.angle[0])
    assert peak == pytest.approx(math.radians(60) + BOUNCE_ANGLE)
    assert leaves.angle[0] == pytest.approx(math.radians(40))
    # Caught again while closing (App. B.2: the next holder interrupts the closing).
    leaves.release(0, bounce=0.0)
    for _ in range(20):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert 0.0 < leaves.angle[0] < math.radians(40)
    leaves.grab(0, open_to=math.radians(80))
    for _ in range(round(1.0 / DT)):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert leaves.angle[0] == pytest.approx(math.radians(80)) and leaves.phase[0] == HELD


def test_the_closer_never_exceeds_the_closing_speed() -> None:
    door = Door(span=((-0.5, 0.0), (0.5, 0.0)), swing="one_way", closing_speed=math.radians(30))
    leaves = DoorLeaves.of_world(WorldConfig(bounds=((-5.0, -5.0), (5.0, 5.0)), doors=(door,)))
    leaves.angle[0] = math.radians(90)
    leaves.side[0] = 1
    leaves.release(0, bounce=0.0)
    prev = leaves.angle[0]
    nobody = np.zeros((0, 2))
    for _ in range(round(2.0 / DT)):
        leaves.step(DT, nobody, nobody, np.zeros(0))
        assert prev - leaves.angle[0] <= math.radians(30) * DT + 1e-12
        prev = leaves.angle[0]
    assert leaves.angle[0] == pytest.approx(math.radians(90 - 60), abs=math.radians(1))


def test_a_hand_never_swings_a_leaf_into_someone() -> None:
    leaves = _leaves(swing="one_way", pull=1)
    bystander = np.array([[0.0, 0.6]])  # in the swing on the pull side
    leaves.grab(0, open_to=math.radians(90))
    for _ in range(round(1.0 / DT)):
        leaves.step(DT, bystander, np.zeros((1, 2)), np.array([R]))
    assert _overlap(leaves, bystander, np.array([R])) <= 1e-9
    assert leaves.angle[0] < math.radians(60)


# -- revolving doors (§4.5.1) ----------------------------------------------------------------------


def _revolving() -> DoorLeaves:
    door = Door(span=((-1.1, 0.0), (1.1, 0.0)), kind="revolving")
    return DoorLeaves.of_world(WorldConfig(bounds=((-5.0, -5.0), (5.0, 5.0)), doors=(door,)))


def test_a_revolving_door_turns_only_when_pushed_and_never_into_anyone() -> None:
    leaves = _revolving()
    assert len(leaves) == 4 and leaves.panel.all() and len(leaves.revolvers) == 1
    nobody = np.zeros((0, 2))
    for _ in range(90):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert leaves.revolvers.rotation[0] == 0.0  # nobody pushes: it stands
    leaves.revolvers.push[0] = 0.5
    for _ in range(180):
        leaves.step(DT, nobody, nobody, np.zeros(0))
    assert leaves.revolvers.rotation[0] > 0.5  # pushed counter-clockwise
    assert np.allclose(leaves.angle, leaves.revolvers.rotation[0])
    # Someone standing still in a compartment that nobody carries stops the door short of them.
    mid = leaves.revolvers.compartment_angle(0, 0)
    standing = 0.65 * np.array([[math.cos(mid), math.sin(mid)]])
    for _ in range(360):
        leaves.step(DT, standing, np.zeros((1, 2)), np.array([R]))
        assert _overlap(leaves, standing, np.array([R])) <= 1e-9
    assert abs(leaves.revolvers.omega[0]) < 1e-9
    # Carried, the same person rides along: the door turns again.
    before = leaves.revolvers.rotation[0]
    leaves.step(DT, standing, np.zeros((1, 2)), np.array([R]), carried=np.array([True]))
    assert leaves.revolvers.rotation[0] > before


def test_the_user_pushes_a_revolving_door_out_of_the_way() -> None:
    leaves = _revolving()
    # The user stands across panel 0 (along +x at rest).
    user = np.array([[0.7, 0.05]])
    leaves.step(DT, user, np.zeros((1, 2)), np.array([R]), fixed=np.array([True]))
    assert _overlap(leaves, user, np.array([R])) <= 1e-9
