"""Step generation for constrained motion around doors (Huang & Terzopoulos App. C.2, Fig. 20).

Between two key poses of the door interaction the root moves a short way, often sideways,
backward or while turning. App. C generates the footsteps that connect the current root
position ``p_rt^curr`` to the target ``p_rt^tgt``; this module is that generator, in 2D ground
coordinates (x, y; headings counter-clockwise from +x). It is a pure function, called when a
door state picks its next key pose (not on the frame path).

With ``d_tgt`` the unit direction to the target, ``d_r`` its right and ``d_l = -d_r``:

1. the first step (the swing foot ``s``) lands at ``p_curr + α d_tgt L_step + d_s W_step``
   (eq. 1), ``α = 1.5`` in the middle of walking, ``1.0`` from standing (Fig. 20d), then is
   kept within ``C_s1`` of the other foot (eq. 2, the distance between the feet);
2. each next step lands at ``p_curr + d_tgt (L_step + m_prev) + d_s W_step`` (eqs. 4, 6), with
   ``m_prev`` the previous step's projection on ``d_tgt`` (eq. 3), kept within ``C_s2`` of
   where the same foot was (eq. 5, how far one foot can step);
3. once ``L_step + m_last > L_tgt`` the last step goes to ``p_tgt + d_1 l_1`` with
   ``d_1`` the unit direction from the last foot to the target and
   ``l_1 = W_step / sin∠(d_1, d_tgt)`` (eqs. 7–9): it lands ``W_step`` to its side of the line;
4. an auxiliary turning step comes first when the line to the target passes behind the
   supporting foot (Fig. 20c): the swing foot would have to cross over it, so it first steps
   beside the support foot, turned toward the target;
5. when the motion must end standing, the last two steps are regenerated beside the target,
   ``p_tgt ∓ d'_r W_step`` with ``d'_r`` the right of the target facing (eqs. 10–11);
6. backward steps (``backward``) are generated the same way, and the root keys face away from
   the direction of travel.

Choices where App. C leaves room: when ``sin∠(d_1, d_tgt)`` is below ``W_step / L_step`` the
last step of eq. 9 would land far past the target (``l_1`` grows without bound), so it lands
beside the target instead (``p_tgt + d_s W_step``). The root keys (App. C: the root has keys in
the two-foot support phase) are the midpoints of consecutive footholds, facing ``d_tgt`` (or
its reverse when backward), and the target facing at the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LEFT, RIGHT = 0, 1
ALPHA_WALKING = 1.5  # eq. 1
ALPHA_STANDING = 1.0  # Fig. 20d
L_STEP = 0.32  # m: a constrained step's length (short steps around the door)
W_STEP = 0.1  # m: half the width between the feet
C_S1 = 0.6  # m: the farthest the feet are apart
C_S2 = 0.7  # m: the farthest one foot steps
MAX_STEPS = 64


@dataclass(frozen=True)
class Footstep:
    """One generated step: which foot, where it lands (2,), the foot's yaw."""

    side: int
    pos: np.ndarray
    yaw: float


@dataclass(frozen=True)
class StepPlan:
    """Generated steps and the root keys between them (``(K, 2)`` positions, ``(K,)`` facings)."""

    steps: tuple[Footstep, ...]
    root: np.ndarray
    facing: np.ndarray
    auxiliary: bool


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _right(d: np.ndarray) -> np.ndarray:
    return np.array([d[1], -d[0]])


def _clamp_from(p: np.ndarray, anchor: np.ndarray, limit: float) -> np.ndarray:
    """``anchor + ||p - anchor||_limit`` (eqs. 2 and 5): ``p`` no farther than ``limit`` from ``anchor``."""
    v = p - anchor
    n = float(math.hypot(v[0], v[1]))
    return p if n <= limit else anchor + v * (limit / n)


def generate_steps(*, root: np.ndarray, left: np.ndarray, right: np.ndarray, swing: int, standing: bool,
                   target: np.ndarray, target_facing: float | None = None, end_standing: bool = True,
                   backward: bool = False, l_step: float = L_STEP, w_step: float = W_STEP,
                   c_s1: float = C_S1, c_s2: float = C_S2) -> StepPlan:
    """Footsteps from the current root and feet (``left``, ``right`` (2,)) to ``target`` (App. C.2).

    ``swing``: the foot that steps next (``LEFT`` or ``RIGHT``); ``standing``: the body stands
    now (``sd``); ``end_standing``: the last step is to a standing pose (``cs.sd``), facing
    ``target_facing`` (default: the direction of travel, reversed when ``backward``).
    """
    p0 = np.asarray(root, np.float64)
    tgt = np.asarray(target, np.float64)
    feet = [np.asarray(left, np.float64).copy(), np.asarray(right, np.float64).copy()]
    delta = tgt - p0
    l_tgt = float(math.hypot(delta[0], delta[1]))
    travel = 0.0 if l_tgt < 1e-9 else math.atan2(delta[1], delta[0])
    face_travel = _wrap(travel + (math.pi if backward else 0.0))
    if target_facing is None:
        target_facing = face_travel
    if l_tgt < 1e-6:
        if not end_standing:
            return StepPlan((), p0[None].copy(), np.array([target_facing]), False)
        return _standing_end(p0, tgt, feet, int(swing), [], target_facing, w_step, c_s2, False, face_travel)
    d_tgt = delta / l_tgt
    d_r = _right(d_tgt)
    side_dir = {RIGHT: d_r, LEFT: -d_r}
    steps: list[Footstep] = []
    s = int(swing)
    aux = False
    support = feet[1 - s]
    # Fig. 20c: the line to the target passes behind the supporting foot when that foot lies on the
    # swing foot's side of the line, or ahead of the root toward the target (the swing foot would
    # cross over or through it): step beside it first.
    rel = support - p0
    if float(rel @ side_dir[s]) > 1e-9 or float(rel @ d_tgt) > 0.5 * w_step:
        aux = True
        p = support + side_dir[s] * (2.0 * w_step)
        p = _clamp_from(p, feet[s], c_s2)
        feet[s] = p
        steps.append(Footstep(s, p.copy(), travel))
        s = 1 - s
    alpha = ALPHA_STANDING if standing and not aux else ALPHA_WALKING
    # eq. 1 and 2: the first step.
    p = p0 + alpha * d_tgt * l_step + side_dir[s] * w_step
    p = _clamp_from(p, feet[1 - s], c_s1)
    m_prev = float((p - p0) @ d_tgt)  # eq. 3
    if m_prev >= l_tgt - 1e-9:
        p = _last(tgt, feet[1 - s], d_tgt, side_dir[s], w_step)
    feet[s] = p
    steps.append(Footstep(s, p.copy(), travel))
    s = 1 - s
    while m_prev < l_tgt - 1e-9 and len(steps) < MAX_STEPS:
        if l_step + m_prev > l_tgt:  # eqs. 7-9: the last step
            p = _last(tgt, feet[1 - s], d_tgt, side_dir[s], w_step)
            p = _clamp_from(p, feet[s], c_s2)
            feet[s] = p
            steps.append(Footstep(s, p.copy(), travel))
            s = 1 - s
            break
        p = p0 + d_tgt * (l_step + m_prev) + side_dir[s] * w_step  # eq. 6
        p = _clamp_from(p, feet[s], c_s2)  # eq. 5
        m_prev = float((p - p0) @ d_tgt)
        feet[s] = p
        steps.append(Footstep(s, p.copy(), travel))
        s = 1 - s
    if end_standing:
        return _standing_end(p0, tgt, [np.asarray(left, np.float64), np.asarray(right, np.float64)], s, steps,
                             target_facing, w_step, c_s2, aux, face_travel)
    return _plan(p0, steps, face_travel, target_facing, aux)


def _last(tgt: np.ndarray, last_foot: np.ndarray, d_tgt: np.ndarray, d_s: np.ndarray,
          w_step: float) -> np.ndarray:
    d1 = tgt - last_foot
    n = float(math.hypot(d1[0], d1[1]))
    if n < 1e-9:
        return tgt + d_s * w_step
    d1 = d1 / n
    sin = abs(float(d1[0] * d_tgt[1] - d1[1] * d_tgt[0]))
    if sin < 0.3:  # eq. 8 would put the step far past the target: beside it instead (module docstring)
        return tgt + d_s * w_step
    return tgt + d1 * (w_step / sin)


def _standing_end(p0: np.ndarray, tgt: np.ndarray, start_feet: list[np.ndarray], s: int,
                  steps: list[Footstep],
                  facing: float, w_step: float, c_s2: float, aux: bool, face_travel: float) -> StepPlan:
    """Eqs. 10-11: the last two steps regenerated beside the target, square to the target facing
    (with steps in between where a foot would otherwise step farther than ``c_s2``)."""
    dr = np.array([math.sin(facing), -math.cos(facing)])  # the right of the facing
    want = {LEFT: tgt - dr * w_step, RIGHT: tgt + dr * w_step}
    out = list(steps)
    if len(out) >= 2 and not (aux and len(out) == 2):
        first = out[-2].side
        out = out[:-2]
    elif out and not aux:
        first = out[0].side
        out = []
    else:
        first = s
    prev = {LEFT: start_feet[LEFT].copy(), RIGHT: start_feet[RIGHT].copy()}
    for st in out:
        prev[st.side] = st.pos
    done = {LEFT: False, RIGHT: False}
    side = first
    while not (done[LEFT] and done[RIGHT]) and len(out) < MAX_STEPS:
        if not done[side]:
            v = want[side] - prev[side]
            n = float(math.hypot(v[0], v[1]))
            if n > c_s2:
                p = prev[side] + v * (c_s2 / n)
                out.append(Footstep(side, p, face_travel))
            else:
                p = want[side].copy()
                out.append(Footstep(side, p, facing))
                done[side] = True
            prev[side] = p
        side = 1 - side
    return _plan(p0, out, face_travel, facing, aux)


def _plan(p0: np.ndarray, steps: list[Footstep], face_travel: float, target_facing: float,
          aux: bool) -> StepPlan:
    """Root keys at double support: midpoints of consecutive footholds."""
    pts = [p0]
    fac = [face_travel]
    for a, b in zip(steps, steps[1:], strict=False):
        pts.append(0.5 * (a.pos + b.pos))
        fac.append(face_travel)
    if steps:
        fac[-1] = target_facing
    return StepPlan(tuple(steps), np.asarray(pts, np.float64).reshape(-1, 2), np.asarray(fac), aux)
