"""VR: the trigger takes a door with the controller near its handle (issue 14).

The presenter passes the located grip pose of the hand that pressed the trigger, as a floor point,
to the etiquette's user hand (``DoorEtiquette.user_hand``), and keeps passing it while the door is
held (``user_hand_moved``: the leaf follows the hand); an untracked controller falls back to the
reach point ahead of the user, as on the desktop. A real door scene; the runtime is a fake port
(``test_session.FakePort``), the grip poses the real port's translation gives
(``test_openxr_translate``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pedvr.crowd.user import StandingUser
from pedvr.sim import Simulation
from pedvr.xr.locomotion import TRACKING_FORWARD, Controls, HeadsetUser
from pedvr.xr.session import Pose, XrPresenter
from tests.etiquette.test_etiquette_sim import _user_scene
from tests.xr.test_session import FOCUS, READY, FakePort

# the scene's door spans (0, -0.55)-(0, 0.55), pulled open to the west, where the user stands
SIDEWAYS = ((-1.6, 0.0), math.pi / 2)  # facing north beside the door: the reach ahead is 1.6 m from it
FACING = ((-0.6, 0.85), math.atan2(-0.4, 0.6))  # facing the handle: the reach ahead is at the leaf


def _grip(x: float, y: float) -> Pose:
    """A grip pose at world floor point (x, y) for the play space of :func:`_take` (tracking (x, z) = world)."""
    return Pose(position=np.array([x, 1.0, y]), orientation=(0.0, 0.0, 0.0, 1.0))


def _take(tmp_path: Path, user: tuple[tuple[float, float], float], hands: list[Pose | None],
          hand: int = 1) -> tuple[Simulation, XrPresenter]:
    """Press the trigger with ``hand`` holding the controllers at ``hands``; run 3 s of frames."""
    scene = _user_scene(tmp_path, route="[[5.0, 0.0]]", pull=-1.0, agent="[5.0, 2.0]")
    sim = Simulation(scene, seed=1, user_input=StandingUser(user[0], heading=user[1]))
    port = FakePort(events=[READY + FOCUS], controls=[Controls(trigger=True, trigger_hand=hand)], hands=hands)
    # A play space whose tracking axes are the world's: its forward (tracking -Z) faces world heading
    # TRACKING_FORWARD (-π/2), so tracking (x, z) is world (x, y).
    user_in = HeadsetUser(start=(0.0, 0.0), heading=TRACKING_FORWARD)
    p = XrPresenter(port, user=user_in, draw_eye=lambda eye, fbo, vp: None)
    sim.advance_to(0.5)
    while sim.t < 3.5:
        timing = p.wait_frame()
        assert timing is not None
        p.render(sim)
        p.end_frame()
        sim.advance_to(sim.t + 1 / 30)
    return sim, p


@pytest.mark.parametrize("tracked", [True, False], ids=["controller", "untracked"])
def test_the_controller_near_the_handle_takes_the_door_where_the_reach_ahead_would_not(
    tmp_path: Path, tracked: bool,
) -> None:
    hands = [None, _grip(-0.95, 0.0) if tracked else None]  # the right hand held out toward the door
    sim, p = _take(tmp_path, SIDEWAYS, hands)
    et = sim.etiquette
    assert et is not None
    if tracked:
        assert et.user_leaf == 0 and p.holding_door
        assert any(e["event"] == "open" and e.get("by") == "user" for e in et.events)
        assert float(np.abs(sim.doors.angle[0])) > math.radians(30)  # opened
    else:  # the fallback: a reach ahead of the user, 1.6 m from the door, takes nothing
        assert et.user_leaf == -1 and not p.holding_door and abs(float(sim.doors.angle[0])) < 1e-9


@pytest.mark.parametrize("tracked", [True, False], ids=["controller", "untracked"])
def test_a_controller_held_back_takes_nothing_and_an_untracked_one_falls_back_to_the_reach(
    tmp_path: Path, tracked: bool,
) -> None:
    # the left hand pressed and is held back, away from the door; the right one (at the handle) did not press
    hands = [_grip(-1.3, 1.3) if tracked else None, _grip(-0.2, 0.5)]
    sim, p = _take(tmp_path, FACING, hands, hand=0)
    et = sim.etiquette
    assert et is not None
    if tracked:
        assert et.user_leaf == -1 and not p.holding_door  # the pressing hand is 1.5 m from the door
    else:
        assert et.user_leaf == 0 and p.holding_door  # the reach ahead of the user, at the handle
    assert p.door_hand == 0


def test_the_held_door_is_given_the_controller_every_frame(tmp_path: Path) -> None:
    sim, p = _take(tmp_path, SIDEWAYS, [None, _grip(-0.95, 0.0)])
    et = sim.etiquette
    assert et is not None and et.user_leaf == 0
    port = p.port
    assert isinstance(port, FakePort)
    port.hands = [None, _grip(-0.8, -0.3)]  # the hand moves, the trigger is not pressed again
    p.wait_frame()
    p.render(sim)
    p.end_frame()
    np.testing.assert_allclose(et.user_hand_point, [-0.8, -0.3])
    assert p.holding_door
    port.hands = [None, None]  # tracking lost: the etiquette is told so (the leaf stays where it is)
    p.wait_frame()
    p.render(sim)
    p.end_frame()
    assert et.user_hand_point is None and p.holding_door
