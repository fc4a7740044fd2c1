"""The engagement gaze (Huang & Kallmann §8, Fig. 17).

"Participants first gazed at the floor during the locomotion, and then
gazed at the target and the observer during the upper-body action." The
gaze at the observer is timed against the action's stroke point by a delay
``Δt`` "correlated with the agent's head rotation angle φ. When the observer
is not at the center of the agent's field of view, the gaze towards the
observer starts before the action reaches the stroke point, resulting in a
negative Δt", and "gaze durations ... decline over time across repeated
demonstrations". The paper gives no numbers for either; pedvr's model:

* ``Δt = −(LEAD + shift / SHIFT_SPEED)``: the gaze leaves the target early
  enough for the head and eyes to turn through ``shift`` degrees (the angle
  between the target and the observer seen from the head, which is the head
  rotation toward the observer, φ's share, plus the pitch up from the
  target) and settle by the stroke, so the demonstrator meets the observer's
  eyes at the stroke point (Fig. 2). An observer straight ahead gives
  ``Δt ≈ −LEAD`` (about 0); one at the side, a clearly negative Δt.
* During the hold the gaze alternates, observer then target, for
  ``OBSERVER_GAZE`` and ``TARGET_GAZE`` seconds, both scaled by
  ``DECLINE ** n`` for the demonstrator's ``n``-th earlier demonstration
  (at least ``MIN_SCALE``).
"""

from __future__ import annotations

import math

import numpy as np

LEAD = 0.1  # s: the eyes alone
SHIFT_SPEED = 150.0  # deg/s: head and eyes together, settled (the body's head is capped at 200 deg/s)
FLOOR_AHEAD = 1.6  # m: where the walking demonstrator looks on the floor
OBSERVER_GAZE = 1.8  # s: a look at the observer during the hold (first demonstration)
TARGET_GAZE = 1.1  # s: a look back at the target
DECLINE = 0.8  # per earlier demonstration by the same demonstrator
MIN_SCALE = 0.4


def shift_deg(head: np.ndarray, target: np.ndarray, observer: np.ndarray) -> float:
    """The angle (deg) between the directions from ``head`` to ``target`` and to ``observer`` (3D)."""
    a = np.asarray(target, np.float64) - np.asarray(head, np.float64)
    b = np.asarray(observer, np.float64) - np.asarray(head, np.float64)
    c = float(np.dot(a, b) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-12))
    return math.degrees(math.acos(min(max(c, -1.0), 1.0)))


def observer_delay(shift: float) -> float:
    """``Δt`` (s, negative: before the stroke) for a gaze shift of ``shift`` degrees."""
    return -(LEAD + abs(shift) / SHIFT_SPEED)


def hold_schedule(start: float, end: float, repeats: int) -> list[tuple[float, str]]:
    """Gaze switches during the hold ``[start, end)``: ``(time, "observer" | "target")``, the
    observer first (the stroke's eye contact continues), durations declining with ``repeats``."""
    scale = max(DECLINE ** max(repeats, 0), MIN_SCALE)
    out: list[tuple[float, str]] = [(start, "observer")]
    t = start + OBSERVER_GAZE * scale
    who = "target"
    while t < end - 1e-9:
        out.append((t, who))
        t += (TARGET_GAZE if who == "target" else OBSERVER_GAZE) * scale
        who = "observer" if who == "target" else "target"
    return out
