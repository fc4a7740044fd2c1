"""Objective measures per trial against hand computations on made-up recordings, and the registry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.study.measures import (
    CONTACT_GAP_S,
    TrialRecord,
    measure_names,
    measures,
    register_measure,
    yaw_of,
)


def _record(xy: np.ndarray, *, dt: float = 0.1, yaw: np.ndarray | None = None, nearest: np.ndarray | None = None,
            spheres: np.ndarray | None = None, contacts: list[tuple[int, int, int, float]] = (),
            outcome: str = "time_limit", gaze: int = 0, demo_gaze: int = 0,
            strokes: list[tuple[int, int, float, float]] = ()) -> TrialRecord:
    n = len(xy)
    t = np.arange(n) * dt
    return TrialRecord(
        trial_id=1, outcome=outcome, sim_time_s=float(t[-1]), t=t, head_xy=np.asarray(xy, dtype=float),
        head_yaw=np.zeros(n) if yaw is None else yaw,
        nearest_agent_m=np.full(n, np.nan) if nearest is None else nearest,
        spheres=np.zeros(n) if spheres is None else spheres,
        user_contacts=np.asarray(contacts, dtype=float).reshape(-1, 4), gaze_starts=gaze,
        demo_gaze_starts=demo_gaze, strokes=np.asarray(strokes, dtype=float).reshape(-1, 4))


def _value(name: str, r: TrialRecord) -> float | None:
    return measures[name].compute(r)


def test_path_length_efficiency_and_finish_time() -> None:
    # start (0,0), east 3 m to the first sphere at frame 3, then a detour north 1 m and east, reaching the
    # second sphere at (6, 0) at frame 9: walked 3 + 1 + 3 + 1 = 8 m, straight lines between reach points 3 + 3.
    xy = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [4, 1], [5, 1], [6, 1], [6, 0.5], [6, 0], [7, 0]])
    spheres = np.array([0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2])
    r = _record(xy, spheres=spheres, outcome="reached_last_sphere")
    assert _value("path_length_m", r) == pytest.approx(9.0)
    assert _value("path_efficiency", r) == pytest.approx(6.0 / 8.0)
    assert _value("time_to_finish_s", r) == pytest.approx(1.0)
    assert _value("time_to_finish_s", _record(xy, spheres=spheres, outcome="time_limit")) is None
    assert _value("path_efficiency", _record(xy)) is None  # no sphere reached
    assert _value("path_efficiency", _record(xy, spheres=np.full(len(xy), np.nan))) is None  # not recorded


def test_min_distance_and_gaze() -> None:
    r = _record(np.zeros((4, 2)), nearest=np.array([np.nan, 2.0, 0.7, 1.1]), gaze=3)
    assert _value("min_distance_m", r) == 0.7
    assert _value("min_distance_m", _record(np.zeros((3, 2)))) is None  # nobody there
    assert _value("gaze_events_received", r) == 3


def test_contacts_are_episodes_of_real_overlap() -> None:
    frames_per_gap = int(round(CONTACT_GAP_S / 0.1))
    contacts = [
        (2, 0, 5, 0.003), (3, 0, 5, 0.004), (4, 0, 5, 0.002),  # one episode with agent 5
        (4 + frames_per_gap, 0, 5, 0.001),  # touching again within the gap: the same contact
        (4 + frames_per_gap + 4, 0, 5, 0.002),  # after a longer gap: a second contact
        (3, 0, 7, 0.010),  # agent 7 at the same time: a third
        (20, 0, 7, 1e-9),  # rounding, not a contact
    ]
    r = _record(np.zeros((30, 2)), contacts=contacts)
    assert _value("contacts", r) == 3
    assert _value("max_overlap_m", r) == pytest.approx(0.010)
    assert _value("contacts", _record(np.zeros((5, 2)))) == 0 and _value("max_overlap_m", _record(np.zeros((5, 2)))) == 0


def test_head_yaw_variability_is_relative_to_the_direction_of_travel() -> None:
    n = 60
    # walking north-east at 1 m/s in straight lines, the head alternating 20 degrees left and right of it
    xy = np.outer(np.arange(n) * 0.1, [math.sqrt(0.5), math.sqrt(0.5)])
    travel = math.atan2(1, 1)
    offsets = np.where(np.arange(n) % 2 == 0, math.radians(20), math.radians(-20))
    r = _record(xy, yaw=travel + offsets)
    # circular SD of +-20 degrees in equal numbers: sqrt(-2 ln cos 20deg)
    assert _value("head_yaw_sd_deg", r) == pytest.approx(math.degrees(math.sqrt(-2 * math.log(math.cos(math.radians(20))))),
                                                        rel=1e-6)
    # looking straight ahead while the route turns: no variability
    theta = np.linspace(0, math.pi, n)
    arc = np.column_stack([5 * np.cos(theta), 5 * np.sin(theta)])
    heading = theta + math.pi / 2
    assert _value("head_yaw_sd_deg", _record(arc, yaw=heading)) == pytest.approx(0.0, abs=0.5)
    assert _value("head_yaw_sd_deg", _record(np.zeros((20, 2)))) is None  # standing still


def test_yaw_from_quaternion() -> None:
    yaw = np.array([0.3, -2.0, 3.0])
    q = np.cos(yaw / 2), np.zeros(3), np.zeros(3), np.sin(yaw / 2)
    assert yaw_of(*q) == pytest.approx(yaw)


def test_registry_names_the_measures_and_refuses_duplicates() -> None:
    assert measure_names() == ["min_distance_m", "contacts", "max_overlap_m", "time_to_finish_s", "path_length_m",
                               "path_efficiency", "head_yaw_sd_deg", "gaze_events_received", "demonstration_gazes",
                               "demonstrations_watched", "doors_held_for_participant"]
    with pytest.raises(ValueError, match="objective measure 'contacts' is already registered"):
        register_measure("contacts", unit="count", label="again")(lambda r: 0.0)
    with pytest.raises(KeyError, match="unknown objective measure 'doors_held'; known: contacts"):
        measures["doors_held"]


def test_demonstrations_watched_need_the_exhibit_in_view_and_near() -> None:
    """A participant standing at the origin, turning its head: 0 rad (east) until frame 10, then north."""
    yaw = np.where(np.arange(20) < 10, 0.0, math.pi / 2)
    xy = np.zeros((20, 2))
    strokes = [
        (3, 0, 3.0, 1.0),  # demonstration 0: the exhibit 18 deg off east at frame 3 -> watched
        (5, 1, 0.0, 3.0),  # demonstration 1: exhibit due north while looking east (90 deg off) -> not ...
        (12, 1, 0.0, 3.0),  # ... but its second stroke finds the head turned north -> watched, once
        (14, 2, 9.0, 9.0),  # demonstration 2: in view (45 deg off north) but 12.7 m away -> not watched
        (15, 3, -4.0, -3.0),  # demonstration 3: behind the head (127 deg off north) -> not watched
    ]
    r = _record(xy, yaw=yaw, strokes=strokes, demo_gaze=4)
    assert _value("demonstrations_watched", r) == 2
    assert _value("demonstration_gazes", r) == 4
    assert _value("demonstrations_watched", _record(xy)) == 0

