"""Objective measures per trial, computed from the recorded samples (the study database).

Each measure is a function of one trial's recording (:class:`TrialRecord`: the
``samples`` rows as arrays, the trial's contacts and gaze events and its
outcome), registered by name in :data:`measures`; the analysis compares every
registered measure across conditions with the same statistics as the
questionnaire scores, the report tables them, and the export writes them
(``trial_measures.tsv``). A new measure is one more function::

    @register_measure("doors_held_for_user", unit="count", label="doors held for the participant")
    def _doors_held(r: TrialRecord) -> float | None: ...


Definitions (choices where the issue leaves room, stated once here):

``min_distance_m``    smallest centre-to-centre distance from the participant to the nearest
                      agent over the trial (the ``nearest_agent_m`` column); none without agents.
``contacts``          contact episodes between the participant and an agent: the frames in which
                      the same pair's discs overlap by more than :data:`CONTACT_MIN_OVERLAP_M`
                      (above rounding, far below anything visible: a 3 mm brush counts), with
                      gaps of at most :data:`CONTACT_GAP_S` joined, count once (the ``contacts``
                      table has one row per overlapping frame).
``max_overlap_m``     the deepest overlap of the participant's disc with an agent's (0 without contact).
``time_to_finish_s``  simulated time at which the last red sphere was reached; none when the
                      trial ended otherwise (time limit, skip).
``path_length_m``     length of the participant's floor path (head position projected on the
                      floor, frame to frame).
``path_efficiency``   the straight-line distance from the start to the point where the first
                      sphere was reached, and on from each reach point to the next, divided by
                      the length walked up to the last sphere reached (1 = straight lines between
                      the points where spheres were reached; never above 1). Reach points rather
                      than sphere centres, because a sphere counts as reached within its radius.
                      None when no sphere was reached or the samples have no sphere counts
                      (databases before schema 3).
``head_yaw_sd_deg``   circular standard deviation of the head's yaw relative to the direction of
                      travel, over frames where the participant moves at least
                      :data:`MOVING_MPS` (direction from positions :data:`DIRECTION_WINDOW_S`
                      apart): how much the participant looks around while walking, not how much
                      the route turns. None with fewer than 2 such frames.
``gaze_events_received``  PedVR gaze-rule gazes at the participant that started in the trial
                      (``gaze_events`` rows ``start`` with target ``user`` and source ``rule``; 0
                      outside PedVR+G).
``demonstration_gazes``  gazes at the participant by demonstrators (PLACE §8: the demonstrator
                      looks the observer in the eyes at the stroke point and again during the
                      talk): ``gaze_events`` rows ``start`` with source ``demonstration``.
``demonstrations_watched``  demonstrations to the participant (``demonstrations`` rows) that the
                      participant watched: at one of its stroke points (the first frame at or after
                      it) the participant was within :data:`WATCH_DISTANCE_M` of the exhibit and the
                      exhibit was within :data:`WATCH_HALF_FOV_DEG` of the head's yaw (about a
                      headset's horizontal field of view, 100–110°). Each demonstration counts once.
                      0 when the trial had no demonstration.
``doors_held_for_participant``  doors an agent held open for the participant in the trial: the
                      agent decided HOF or HOL for the participant (``door_events`` rows ``hold``
                      with the user, action HOF or HOL), whether or not the participant then came
                      (Huang & Terzopoulos §5; a study can ask whether participants noticed courtesy).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from pedvr.registry import Registry
from pedvr.study.store import StudyStore

CONTACT_MIN_OVERLAP_M = 1e-4  # m: overlaps below this are rounding, not contact
CONTACT_GAP_S = 0.25  # s: a pair touching again within this is the same contact
MOVING_MPS = 0.3  # m/s: slower frames say little about the direction of travel
DIRECTION_WINDOW_S = 0.2  # s between the positions that give the direction of travel
WATCH_DISTANCE_M = 7.0  # m: farther from the exhibit, the participant did not watch its demonstration
WATCH_HALF_FOV_DEG = 55.0  # deg either side of the head's yaw: the exhibit was in view
COMPLETE_OUTCOMES = ("reached_last_sphere", "time_limit")


@dataclass(frozen=True)
class TrialRecord:
    """One trial's recording as arrays (F frames, in frame order).

    ``t`` simulated time (s), ``head_xy`` the head position on the floor (m),
    ``head_yaw`` its yaw (rad, from the orientation quaternion, z up),
    ``nearest_agent_m`` (NaN where no agent), ``spheres`` the red spheres
    reached so far (NaN where not recorded); ``user_contacts`` ``(C, 4)``
    rows ``frame, agent_a, agent_b, overlap_m`` of frames where the
    participant's disc overlapped an agent's; ``gaze_starts`` the number of
    gaze-rule gazes that started at the participant; ``demo_gaze_starts`` the demonstrators';
    ``strokes`` ``(S, 4)`` rows ``frame, demo_id, x, y`` of the stroke points of demonstrations to the
    participant (``x, y`` the exhibit).
    """

    trial_id: int
    outcome: str | None
    sim_time_s: float | None
    t: np.ndarray
    head_xy: np.ndarray
    head_yaw: np.ndarray
    nearest_agent_m: np.ndarray
    spheres: np.ndarray
    user_contacts: np.ndarray
    gaze_starts: int
    demo_gaze_starts: int = 0
    strokes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    doors_held_for_user: int = 0


@dataclass(frozen=True)
class Measure:
    """A named per-trial measure: ``compute(record)`` gives the value, or None where undefined."""

    name: str
    unit: str
    label: str
    compute: Callable[[TrialRecord], float | None]


measures: Registry[Measure] = Registry("objective measure")
_ORDER: list[str] = []  # registration order, for tables (the registry iterates by name)


def measure_names() -> list[str]:
    """The registered measures in the order they were registered (the report's row order)."""
    return list(_ORDER)


def register_measure(
    name: str, *, unit: str, label: str
) -> Callable[[Callable[[TrialRecord], float | None]], Measure]:
    """Register ``fn`` as the measure ``name`` (module docstring)."""

    def add(fn: Callable[[TrialRecord], float | None]) -> Measure:
        m = Measure(name=name, unit=unit, label=label, compute=fn)
        measures.register(name)(m)
        _ORDER.append(name)
        return m

    return add


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


@register_measure("min_distance_m", unit="m", label="minimum distance to the nearest agent")
def _min_distance(r: TrialRecord) -> float | None:
    d = r.nearest_agent_m[np.isfinite(r.nearest_agent_m)]
    return float(d.min()) if d.size else None


@register_measure("contacts", unit="count", label="contacts with agents")
def _contacts(r: TrialRecord) -> float | None:
    c = r.user_contacts[r.user_contacts[:, 3] > CONTACT_MIN_OVERLAP_M]
    if c.size == 0:
        return 0.0
    c = c[np.lexsort((c[:, 0], c[:, 2], c[:, 1]))]
    if len(r.t) == 0:  # contacts are committed with their samples, so this does not happen
        return None
    t = r.t[np.clip(c[:, 0].astype(np.int64), 0, len(r.t) - 1)]  # frames are numbered 0, 1, ... in samples
    same_pair = (c[1:, 1] == c[:-1, 1]) & (c[1:, 2] == c[:-1, 2])
    gap = t[1:] - t[:-1]
    continues = same_pair & (gap <= CONTACT_GAP_S + 1e-9)
    return float(1 + np.count_nonzero(~continues))


@register_measure("max_overlap_m", unit="m", label="deepest overlap with an agent")
def _max_overlap(r: TrialRecord) -> float | None:
    return float(r.user_contacts[:, 3].max()) if len(r.user_contacts) else 0.0


@register_measure("time_to_finish_s", unit="s", label="time to finish the route")
def _time_to_finish(r: TrialRecord) -> float | None:
    return r.sim_time_s if r.outcome == "reached_last_sphere" else None


def _steps(xy: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.diff(xy, axis=0), axis=1) if len(xy) > 1 else np.zeros(0)


@register_measure("path_length_m", unit="m", label="path length")
def _path_length(r: TrialRecord) -> float | None:
    return float(_steps(r.head_xy).sum())


@register_measure("path_efficiency", unit="ratio", label="path efficiency")
def _path_efficiency(r: TrialRecord) -> float | None:
    s = r.spheres
    if s.size == 0 or not np.isfinite(s).all():
        return None
    k = int(s[-1])
    if k < 1:
        return None
    reach = [0] + [int(np.argmax(s >= i)) for i in range(1, k + 1)]
    pts = r.head_xy[reach]
    ideal = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    walked = float(_steps(r.head_xy[: reach[-1] + 1]).sum())
    return ideal / walked if walked > 0 else None


@register_measure("head_yaw_sd_deg", unit="deg", label="head-yaw variability (relative to travel)")
def _head_yaw_sd(r: TrialRecord) -> float | None:
    n = len(r.t)
    if n < 3:
        return None
    dt = float(np.median(np.diff(r.t)))
    w = max(1, int(round(DIRECTION_WINDOW_S / (2 * dt)))) if dt > 0 else 1
    i = np.arange(w, n - w)
    if i.size == 0:
        return None
    d = r.head_xy[i + w] - r.head_xy[i - w]
    span = r.t[i + w] - r.t[i - w]
    speed = np.linalg.norm(d, axis=1) / np.where(span > 0, span, np.inf)
    moving = speed >= MOVING_MPS
    if np.count_nonzero(moving) < 2:
        return None
    travel = np.arctan2(d[moving, 1], d[moving, 0])
    rel = r.head_yaw[i[moving]] - travel
    mean_resultant = float(np.hypot(np.cos(rel).mean(), np.sin(rel).mean()))
    return math.degrees(math.sqrt(max(0.0, -2.0 * math.log(max(mean_resultant, 1e-12)))))


@register_measure("gaze_events_received", unit="count", label="gaze events received (PedVR+G)")
def _gaze(r: TrialRecord) -> float | None:
    return float(r.gaze_starts)


@register_measure("demonstration_gazes", unit="count", label="gazes received from demonstrators")
def _demo_gaze(r: TrialRecord) -> float | None:
    return float(r.demo_gaze_starts)


@register_measure("demonstrations_watched", unit="count", label="demonstrations watched")
def _watched(r: TrialRecord) -> float | None:
    if len(r.strokes) == 0 or len(r.t) == 0:
        return 0.0
    k = np.clip(r.strokes[:, 0].astype(np.int64), 0, len(r.t) - 1)  # samples are numbered 0, 1, ...
    d = r.strokes[:, 2:4] - r.head_xy[k]
    near = np.hypot(d[:, 0], d[:, 1]) <= WATCH_DISTANCE_M
    off = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - r.head_yaw[k])))
    seen = near & (np.abs(off) <= math.radians(WATCH_HALF_FOV_DEG))
    return float(len(set(r.strokes[seen, 1].astype(np.int64).tolist())))
@register_measure("doors_held_for_participant", unit="count", label="doors held for the participant")
def _doors_held(r: TrialRecord) -> float | None:
    return float(r.doors_held_for_user)


def yaw_of(qw: np.ndarray, qx: np.ndarray, qy: np.ndarray, qz: np.ndarray) -> np.ndarray:
    """Yaw (rad) of orientation quaternions about the world's z axis (the head's forward is +x)."""
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def load_trials(store: StudyStore, trial_ids: list[int] | None = None) -> Iterator[TrialRecord]:
    """The recording of every trial (or of ``trial_ids``), in trial order.

    One trial's samples are read at a time (the ``samples`` key is ``(trial_id, frame)``), so a large
    study needs the memory of its longest trial, not of all of them.
    """
    where = "" if trial_ids is None else f" WHERE trial_id IN ({','.join(str(int(t)) for t in trial_ids)})"
    trials = store.db.execute(f"SELECT trial_id, outcome, sim_time_s FROM trials{where} ORDER BY trial_id")
    gaze = dict(
        store.db.execute(
            "SELECT trial_id, COUNT(*) FROM gaze_events WHERE event = 'start' AND target = 'user' "
            "AND source = 'rule' GROUP BY trial_id"
        ).fetchall()
    )
    demo_gaze = dict(
        store.db.execute(
            "SELECT trial_id, COUNT(*) FROM gaze_events WHERE event = 'start' AND target = 'user' "
            "AND source = 'demonstration' GROUP BY trial_id"
        ).fetchall()
    )
    held = dict(
        store.db.execute(
            "SELECT trial_id, COUNT(*) FROM door_events WHERE event = 'hold' AND with_user = 1 "
            "AND action IN ('HOF', 'HOL') GROUP BY trial_id"
        ).fetchall()
    )
    for tid, outcome, sim_time_s in trials.fetchall():
        x = np.asarray(
            store.db.execute(
                "SELECT sim_t, head_x, head_y, head_qw, head_qx, head_qy, head_qz, nearest_agent_m, spheres "
                "FROM samples WHERE trial_id = ? ORDER BY frame",
                (tid,),
            ).fetchall(),
            dtype=float,
        ).reshape(-1, 9)  # None (NULL) becomes NaN
        contacts = np.asarray(
            store.db.execute(
                "SELECT frame, agent_a, agent_b, overlap_m FROM contacts "
                "WHERE trial_id = ? AND with_user = 1 ORDER BY frame",
                (tid,),
            ).fetchall(),
            dtype=float,
        ).reshape(-1, 4)
        strokes = np.asarray(
            store.db.execute(
                "SELECT frame, demo_id, x, y FROM demonstrations WHERE trial_id = ? AND event = 'stroke' "
                "ORDER BY frame",
                (tid,),
            ).fetchall(),
            dtype=float,
        ).reshape(-1, 4)
        yield TrialRecord(
            trial_id=int(tid),
            outcome=None if outcome is None else str(outcome),
            sim_time_s=None if sim_time_s is None else float(sim_time_s),
            t=x[:, 0],
            head_xy=x[:, 1:3],
            head_yaw=yaw_of(x[:, 3], x[:, 4], x[:, 5], x[:, 6]),
            nearest_agent_m=x[:, 7],
            spheres=x[:, 8],
            user_contacts=contacts,
            gaze_starts=int(gaze.get(tid, 0)),
            demo_gaze_starts=int(demo_gaze.get(tid, 0)),
            strokes=strokes,
            doors_held_for_user=int(held.get(tid, 0)),
        )


TRIAL_COLUMNS = (
    "trial_id",
    "participant",
    "design",
    "block",
    "scenario",
    "condition",
    "label",
    "trial_order",
    "responsibility",
    "outcome",
)


def trial_measures(store: StudyStore) -> pd.DataFrame:
    """One row per trial: its design columns, ``complete`` (1 when it ran to its end: the last
    sphere or the time limit) and every registered measure (NaN where undefined)."""
    trials = pd.read_sql_query(f"SELECT {', '.join(TRIAL_COLUMNS)} FROM trials ORDER BY trial_id", store.db)
    values: dict[int, dict[str, float | None]] = {}
    for rec in load_trials(store):
        values[rec.trial_id] = {
            name: _finite_or_none(measures[name].compute(rec)) for name in measure_names()
        }
    trials["complete"] = trials["outcome"].isin(COMPLETE_OUTCOMES).astype(int)
    for name in measure_names():
        trials[name] = [values.get(int(t), {}).get(name) for t in trials["trial_id"]]
        trials[name] = trials[name].astype(float)
    return trials


def _finite_or_none(v: float | None) -> float | None:
    return None if v is None else _finite(float(v))
