"""Doors inside the simulation: the user pushes a door open by walking through it, leaves
reach the renderer's snapshot, and a run with doors is deterministic."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _office() -> Simulation:
    return Simulation(load_any(resolve_scene("office_doors"), seed=None), record=True)


def test_the_user_walking_through_opens_the_single_door() -> None:
    sim = _office()
    assert len(sim.doors) == 3  # a single door and a double door's two leaves
    crossed_at = None
    while sim.t < 8.0 and crossed_at is None:
        before = sim.crowd.pos[0, 0]
        sim.step()
        if before < 0.0 <= sim.crowd.pos[0, 0]:
            crossed_at = abs(float(sim.doors.angle[0]))
    assert crossed_at is not None, "the scripted user did not reach the single door in 8 s"
    assert crossed_at >= math.radians(70)
    assert sim.doors.side[0] == -1  # the single door's + side is -x: it swung east, away from the user
    snap = Snapshot.from_sim(sim)
    assert snap.doors is not None and snap.doors.shape == (3, 5)
    np.testing.assert_allclose(snap.doors[:, 2], sim.doors.base + sim.doors.angle)


def test_same_seed_same_door_motion_and_it_is_recorded() -> None:
    runs = []
    for _ in range(2):
        sim = _office()
        sim.advance_to(10.0)
        arr = sim.recording.arrays()
        # The recording keeps every leaf's angle per step, ending where the doors are now.
        assert arr["door_angle"].shape == (arr["t"].shape[0], 3)
        np.testing.assert_array_equal(arr["door_angle"][-1], sim.doors.angle)
        assert np.abs(arr["door_angle"]).max() > 1.0  # some leaf opened more than 57 degrees
        runs.append((arr["door_angle"].tobytes(), arr["pos"].tobytes()))
    assert runs[0] == runs[1]


@pytest.mark.parametrize(("user", "walker", "state"), [((7.0, 0.0), (-3.0, 0.0), "east"),
                                                    ((-5.0, 0.0), (3.0, 0.0), "west")])
def test_the_scripted_participant_lets_one_coming_through_pass_first(
        user: tuple[float, float], walker: tuple[float, float], state: str) -> None:
    """A walker comes through door_same_side's door toward the scripted participant (``DoorUser``)
    as the participant reaches it from the other side (seed 1). First: the walker (3 m west) pulls
    the door open as the participant (7 m east) comes to it from the push side; the participant
    walked on into the doorway, and the two stood facing each other in it: neither was through
    after 30 s. Second: the walker (3 m east) pushes the door open toward the participant (5 m
    west, on the pull side); the participant walked into the doorway too, and the walker was
    through at 22.9 s, the participant at 26.6 s. A person lets the one coming through pass
    first: it now steps aside, off the lane beside the doorway, until nobody is coming and the
    doorway is clear (``DoorUser._step_aside``); on the pull side it then goes back onto the lane
    and to the handle, and opens the door itself. Measured: the walker through at 7.0 and 8.2 s,
    the participant at 10.0 and 14.3 s. Nothing touches the participant."""
    from pedvr.etiquette.user import GIVE_WAY

    s = load_any(resolve_scene("door_same_side"), seed=None)
    spawn = dataclasses.replace(s.spawns[0], state=state, positions=(walker,), count=0, region=None)
    s = dataclasses.replace(s, spawns=(spawn,),
                            user=dataclasses.replace(s.user, start=user, route=((-user[0], 0.0),)))
    sim = Simulation(s, seed=1)
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    east = user[0] > 0.0  # the participant comes from the east, the walker from the west
    gave_way, through = False, {}
    while sim.t < 20.0 and len(through) < 2:
        sim.step()
        gave_way |= sim.user.source.mode == GIVE_WAY  # type: ignore[attr-defined]
        wx, ux = float(sim.crowd.pos[row, 0]), float(sim.crowd.pos[sim.crowd.is_user][0][0])
        if "walker" not in through and (wx > 0.5 if east else wx < -0.5):
            through["walker"] = sim.t
        if "user" not in through and (ux < -0.5 if east else ux > 0.5):
            through["user"] = sim.t
    assert gave_way and set(through) == {"walker", "user"}, (sim.t, through)
    assert through["walker"] < through["user"], through
    summary = sim.summary()
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0
    assert summary["door_leaf_overlap_max_m"] < 0.01
