"""The demonstrative action (Huang & Kallmann §6): pointing or touching with the right arm.

PLACE synthesises the action by inverse blending of motion-capture examples;
pedvr has no such database, so the action is parameterised by the hand's
trajectory instead, and the body's arm IK (``reach_for``, :mod:`pedvr.body`)
follows it. The hand leaves its rest position beside the hip, rises along a
smooth arc to the stroke point, holds there while the demonstrator speaks,
and returns. The paper's collision avoidance in blending space becomes the
same procedure in hand space (§6, Fig. 14): the obstacles near the arm are
approximated by small spheres ``S_i``, the collision potential is

    P_c(E) = exp(−Σ_i distance(E, S_i))

over the spheres within :data:`NEAR` of the end effector ``E``, and a single
pass from the first frame to the last moves each frame that is closer than
:data:`CLEARANCE` to an obstacle down the gradient of ``P_c`` (away from the
spheres) until it is clear, then spreads that correction over a smoothness
window of neighbouring frames. The stroke point itself is never moved: if
it collides the action is infeasible from that placement, and the planner
looks elsewhere (§4).

Feasibility (the planner's ``action`` test): pointing needs the target in
front of or to the right of the body (:data:`POINT_AZIMUTH`) and not closer
than :data:`POINT_MIN` of the arm; the hand stops :data:`POINT_SHORT` short of
the target on the line from the shoulder, at most :data:`POINT_EXTENSION` of
the arm's length out. Touching needs the target within :data:`TOUCH_REACH` of
the arm from the shoulder. Either way the arm and hand at the stroke must be
outside every obstacle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pedvr.demonstrator import kernels as kn
from pedvr.demonstrator.stage import Figure, Stage

ACTIONS = ("point", "touch")
POINT_EXTENSION = 0.92  # share of the arm's length the pointing hand reaches out
POINT_SHORT = 0.15  # m: the pointing hand stops this far short of the target
POINT_MIN = 0.35  # share of the arm: a target nearer the shoulder than this is touched, not pointed at
POINT_AZIMUTH = (-40.0, 120.0)  # deg from the facing, + to the right (the pointing arm's side)
TOUCH_REACH = 0.97  # share of the arm's length the touching hand may use
TOUCH_AZIMUTH = (-30.0, 100.0)
HAND_ABOVE = 0.05  # m: the touching hand joint stays this far above the point touched
POINT_BASE, POINT_PER_SIZE, POINT_RANGE = 0.9, 1.0, (0.8, 2.5)  # d_pref = base + per_size·size, clamped
CLEARANCE = 0.05  # m the hand keeps from obstacle surfaces along its path
NEAR = 0.4  # m: spheres farther than this from the hand do not enter its potential
RESOLUTION = 0.025  # m of hand travel between trajectory frames ("relative to the distance covered")
WINDOW = 5  # frames over which a correction is spread on each side
STEP = 0.01  # m per gradient step
MAX_STEPS = 40


@dataclass(frozen=True)
class Action:
    """What is demonstrated: ``kind`` (``point`` or ``touch``) at ``target`` (ground m) and
    ``height`` (m, the point addressed: the object's top), from ``d_pref`` m away (§4)."""

    kind: str
    target: tuple[float, float]
    height: float
    d_pref: float


def preferred_distance(kind: str, figure: Figure, *, height: float, size: float,
                       d_pref: float | None = None) -> float:
    """``d_pref`` (§4): "action-dependent ... selected according to reachability constraints if
    the demonstration has to achieve object contact, or in other cases (like in pointing), ... a
    user-specified parameter fixed or dependent on features of the environment (like the size of
    the target)".

    Pointing: ``d_pref`` if given, else ``0.9 + 1.0 · size`` m within [0.8, 2.5] (pedvr's choice:
    a bigger object is shown from farther). Touching: the ground distance from which the right
    hand reaches the target with 90 % of the arm, the target straight ahead of the shoulder.
    """
    if d_pref is not None:
        return float(d_pref)
    if kind == "point":
        return float(min(max(POINT_BASE + POINT_PER_SIZE * size, POINT_RANGE[0]), POINT_RANGE[1]))
    sx, sy, _ = figure.shoulder
    drop = sy - (height + HAND_ABOVE)
    r = 0.9 * figure.arm
    ahead = math.sqrt(max(r * r - drop * drop, 0.0))
    return max(math.hypot(sx, ahead), figure.radius + 0.05)


def _azimuth(v: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """Degrees from the facing to ground direction ``v (M, 2)``, positive toward the body's right."""
    a = np.arctan2(v[:, 1], v[:, 0]) - heading
    return np.degrees((a + np.pi) % (2 * np.pi) - np.pi)


def stroke_points(stage: Stage, figure: Figure, action: Action, pos: np.ndarray,
                  heading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Feasibility and stroke hand point for bodies at ``pos (M, 2)`` facing ``heading (M,)``.

    Returns ``(feasible (M,) bool, stroke (M, 3))`` with 3D points ``(x, h, y)``.
    """
    pos = np.asarray(pos, np.float64).reshape(-1, 2)
    heading = np.asarray(heading, np.float64).reshape(-1)
    m = len(pos)
    sh = figure.world(pos, heading, figure.shoulder)
    tgt = np.array([action.target[0], action.height, action.target[1]])
    v = tgt - sh
    dist = np.linalg.norm(v, axis=1)
    unit = v / np.maximum(dist, 1e-9)[:, None]
    az = _azimuth(v[:, [0, 2]], heading)
    if action.kind == "point":
        lo, hi = POINT_AZIMUTH
        reach = np.minimum(POINT_EXTENSION * figure.arm, dist - POINT_SHORT)
        ok = (az >= lo) & (az <= hi) & (reach >= POINT_MIN * figure.arm)
        stroke = sh + unit * reach[:, None]
    else:
        lo, hi = TOUCH_AZIMUTH
        hand = np.repeat((tgt + np.array([0.0, HAND_ABOVE, 0.0]))[None, :], m, 0)
        ok = (az >= lo) & (az <= hi) & (np.linalg.norm(hand - sh, axis=1) <= TOUCH_REACH * figure.arm)
        stroke = hand
    if ok.any():
        idx = np.flatnonzero(ok)
        # the arm from shoulder to hand, and a little past the hand (the fingers), out of every obstacle
        ts = np.asarray([0.25, 0.5, 0.75, 1.0])
        seg = stroke[idx] - sh[idx]
        pts = sh[idx, None, :] + ts[None, :, None] * seg[:, None, :]
        tip = stroke[idx] + 0.1 * seg / np.maximum(np.linalg.norm(seg, axis=1), 1e-9)[:, None]
        allp = np.concatenate([pts, tip[:, None, :]], 1).reshape(-1, 3)
        bad = stage.inside(allp).reshape(len(idx), -1).any(axis=1)
        ok[idx[bad]] = False
    return ok, stroke


def collision_potential(points: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """``P_c (M,)`` of §6 for end-effector points ``(M, 3)``: ``exp(−Σ distance(E, S_i))`` over the
    spheres within :data:`NEAR` (distance to a sphere's surface, 0 inside it); 0 with none near."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    if len(spheres) == 0:
        return np.zeros(len(p))
    d = np.linalg.norm(p[:, None, :] - spheres[None, :, :3], axis=2)
    near = d <= NEAR
    surf = np.maximum(d - spheres[None, :, 3], 0.0)
    return np.where(near.any(axis=1), np.exp(-(surf * near).sum(axis=1)), 0.0)


def hand_path(stage: Stage, figure: Figure, *, pos: tuple[float, float], heading: float,
              stroke: tuple[float, float, float]) -> tuple[np.ndarray, int]:
    """The hand's path ``(K, 3)`` from rest to the stroke point, and how many frames were adjusted.

    An arc (quadratic Bézier: out in front of the body and up a little)
    sampled every :data:`RESOLUTION` m, then §6's single avoidance pass over
    the collision potential (module docstring). The first (rest) and last
    (stroke) frames are kept.
    """
    start = figure.world(np.asarray([pos]), np.asarray([heading]), figure.hand_rest)[0]
    end = np.asarray(stroke, np.float64)
    fwd = np.array([math.cos(heading), 0.0, math.sin(heading)])
    ctrl = 0.5 * (start + end) + 0.12 * fwd + np.array([0.0, 0.05, 0.0])
    approx = float(np.linalg.norm(ctrl - start) + np.linalg.norm(end - ctrl))
    n = max(8, int(math.ceil(approx / RESOLUTION)) + 1)
    u = np.linspace(0.0, 1.0, n)[:, None]
    path = (1 - u) ** 2 * start + 2 * (1 - u) * u * ctrl + u**2 * end
    shoulder = figure.world(np.asarray([pos]), np.asarray([heading]), figure.shoulder)[0]
    spheres = stage.spheres(shoulder, figure.arm + NEAR)
    adjusted = 0
    if len(spheres):
        adjusted = int(kn.avoid_kernel(path, np.ascontiguousarray(spheres), CLEARANCE, NEAR, STEP, MAX_STEPS,
                                       WINDOW))
    return path, adjusted


def min_jerk_times(n: int, duration: float) -> np.ndarray:
    """Times ``(n,)`` in [0, duration] at which a minimum-jerk motion passes ``n`` equally spaced
    path frames (smooth start and stop): ``s(τ) = 10τ³ − 15τ⁴ + 6τ⁵``."""
    tau = np.linspace(0.0, 1.0, 512)
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    return np.interp(np.linspace(0.0, 1.0, n), s, tau) * duration
