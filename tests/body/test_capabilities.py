"""A bad capability call changes nothing: it raises one clear UsageError before any handle or state moves."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.body import Status
from pedvr.errors import UsageError
from tests.body._walk import bodies, drive


def _snapshot(b) -> bytes:  # type: ignore[no-untyped-def]
    st = b.state
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (
        st.g_kind, st.g_start, st.g_dur, st.gaze_kind, st.gaze_point, st.gaze_agent, st.reach_on, st.reach_pt))


def test_unknown_gesture_leaves_the_running_one_alone() -> None:
    b = bodies(1)
    wave = b.gesture(0, "wave", duration=1.0)
    drive(b, lambda t: np.zeros((1, 2)), lambda t: np.zeros(1), 0.3)
    before, handles = _snapshot(b), list(b.handles)
    with pytest.raises(UsageError, match=r"gesture 'juggle': unknown; known: wave, point"):
        b.gesture(0, "juggle")
    assert _snapshot(b) == before
    assert b.handles == handles and wave.status is Status.RUNNING and wave.detail == ""
    with pytest.raises(UsageError, match=r"gesture 'wave': duration = -1.0: must be a positive number"):
        b.gesture(0, "wave", duration=-1.0)
    with pytest.raises(UsageError, match=r"duration = nan"):
        b.gesture(0, "shrug", duration=float("nan"))
    assert _snapshot(b) == before
    assert b.handles == handles and wave.status is Status.RUNNING and wave.detail == ""
    drive(b, lambda t: np.zeros((1, 2)), lambda t: np.zeros(1), 1.0, t0=0.3)
    assert wave.status is Status.SUCCESS and wave.detail == ""  # it played to its end, not "stopped"
    assert not b.handles  # and no RUNNING handle was left for the bad name


def test_bad_gaze_and_reach_targets_change_nothing() -> None:
    b = bodies(1)
    gz = b.gaze_at(0, (3.0, 1.6, 2.0))
    reach = b.reach_for(0, (0.35, 1.1, 0.3))
    before, handles = _snapshot(b), list(b.handles)
    with pytest.raises(UsageError, match=r"gaze_at target 'sky': expected a 3D point"):
        b.gaze_at(0, "sky")
    with pytest.raises(UsageError, match=r"gaze_at target \(1.0, nan, 0.0\): expected a finite 3D point"):
        b.gaze_at(0, (1.0, float("nan"), 0.0))
    with pytest.raises(UsageError, match=r"reach_for side 'middle': expected 'left' or 'right'"):
        b.reach_for(0, (0.3, 1.0, 0.3), side="middle")
    with pytest.raises(UsageError, match=r"reach_for target \(1, 2\): expected a 3D point"):
        b.reach_for(0, (1, 2))
    assert _snapshot(b) == before and b.handles == handles
    assert gz.running and reach.running
