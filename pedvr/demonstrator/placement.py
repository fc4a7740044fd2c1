"""PLACE's placement search (Huang & Kallmann §4): candidates around the target, validity, ranking.

Given the action (its target and preferred distance ``d_pref``), the observer
and the demonstrator's body, :class:`PlacementSearch` proposes placements
from the model (:mod:`pedvr.demonstrator.model`) for frame orientations every
5° around the target in both directions, starting from the table's Z axis;
each is tested for validity and, if it collides, tried again a few times with
a perturbed distance and orientation. The valid placements are ranked by

    f = w_v · e_vis + w_n · e_neck + w_a · e_action

and the sorted list is kept (:class:`Plan`): when motion synthesis fails
later, the next one is used.

When the model's candidates give no valid placement (§4 perturbs only
colliding candidates, and only slightly: an observer standing behind a pillar
can leave none at ``d_pref`` while there are many a metre farther out), the
search widens: every failing candidate, hidden ones included, is tried over a
wider range of distances and orientations; if that still finds none, it falls
back to placements off the model (facing the observer, farther out) that keep
every hard constraint, visibility first. Only when nothing is visible at all is
the list empty. Which pass found the list is on the :class:`Plan` and on each
:class:`Placement` (``origin``); see :class:`PlacementSearch` (issue 24).

Validity of a candidate (§4; each failure is counted by reason in :class:`Plan`):

``collision``   the demonstrator's disc off the walkable mesh (it would overlap an
                obstacle), or within reach of the observer's body (personal space
                :data:`OBSERVER_GAP`) or of a disc to keep clear (another
                demonstrator's placement).
``unreachable`` no path with the mesh's clearance from where the demonstrator stands.
``action``      the arm cannot point at (or reach) the target from there, or the hand or arm
                would be inside an obstacle at the stroke (:mod:`pedvr.demonstrator.arm`).
``visibility``  the observer's head is hidden from the demonstrator's by more than
                :data:`VIS_DISCARD` (2D crossing and 3D check against heights, partial occluders
                multiply), or the demonstrator would stand in the observer's line of sight to
                the target (pedvr's addition: the body hides the exhibit).
``eye_contact`` the rotation needed to look the observer in the eyes exceeds what the head may
                turn (limited by φ, see below) plus what the eyes can do.

Costs (the paper gives no weights, only that uncomfortable but feasible
placements beat bad visibility; pedvr's choice):

``e_vis``     the occluded share of the head-to-head sight line, in [0, 1];
``e_neck``    the rotation (degrees) from the body's orientation to the observer's head
              (what neck, head and eyes must do for eye contact);
``e_action``  ``|d_pref − ‖p_d − p_t‖|`` in metres.

``W_VIS = 1000`` per unit of occlusion, ``W_NECK = 1`` per degree, ``W_ACTION = 20``
per metre: any occluder hiding 20 % or more costs more than the largest neck rotation
(180°) and any distance error the search makes (perturbations stay within 0.4 m), so
visibility dominates.

Head rotation (Appendix A: "the maximum head rotation limits the amount of head rotation
allowed, and the remaining needed rotation for achieving eye contact with the observer is
performed with eye rotation"): the head may turn relative to the body by ``|φ − θ|`` (at
least :data:`HEAD_MIN`); the eyes turn at most :data:`EYE_LIMIT` more.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pedvr.demonstrator import kernels as kn
from pedvr.demonstrator.arm import Action, stroke_points
from pedvr.demonstrator.model import global_heading, local_angle, placement_model_array, wrap_deg
from pedvr.demonstrator.stage import Figure, Stage

STEP_DEG = 5.0  # rotation increment of the frame around the target (§4: "five degrees in both directions")
N_DIRECTIONS = 72  # 360 / 5: the exhaustive search
W_VIS, W_NECK, W_ACTION = 1000.0, 1.0, 20.0
VIS_DISCARD = 0.6  # occluded share above which a candidate is discarded (a full occluder, two plants)
HEAD_MIN = 15.0  # deg: the head may always turn this much toward the observer
HEAD_MAX = 100.0  # deg: the body's gaze chain (lumbar, thorax, neck, head) turns at most about this
EYE_LIMIT = 30.0  # deg: what the eyes add (the body's eyes turn 35°; 5° kept in reserve)
OBSERVER_GAP = 0.35  # m between the demonstrator's disc and the observer's (personal space)
KEEP_CLEAR_GAP = 0.1  # m between the demonstrator's disc and another demonstrator's placement
VIEW_GAP = 0.05  # m: the body keeps out of the observer's sight line to the target by this
# Perturbations of a colliding candidate: (distance factor, orientation offset deg), tried in order.
PERTURB = ((0.85, 0.0), (1.15, 0.0), (0.7, 10.0), (1.3, -10.0), (0.7, -10.0), (1.3, 10.0))
REASONS = ("collision", "unreachable", "action", "visibility", "eye_contact")
PASSES = ("model", "wide", "fallback")  # see PlacementSearch
# The wide pass (no valid placement from the model): distances as factors of d_pref, nearest it
# first, and body orientations about θ (deg); every combination of each orientation is tried.
WIDE_FACTORS = (1.0, 0.85, 1.15, 0.7, 1.3, 1.5, 1.75, 2.0)
WIDE_TURNS = (0.0, 10.0, -10.0, 20.0, -20.0)
# The fallback (none even so): the body faces the observer turned by these (deg), and rings every
# FALLBACK_RING m beyond the wide pass's out to FALLBACK_FAR m from the target.
FALLBACK_TURNS = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0)
FALLBACK_RING, FALLBACK_FAR = 0.5, 5.0
WIDE_SHARE = 4  # a wide or fallback orientation costs about this many of the model pass's


@dataclass(frozen=True)
class Observer:
    """Who watches: ground position, eye height (m) and disc radius (m)."""

    pos: tuple[float, float]
    eye_height: float = 1.6
    radius: float = 0.25


@dataclass(frozen=True)
class Placement:
    """A valid placement: where the demonstrator stands and faces, the model's angles, its costs.

    ``pos`` ground m; ``heading`` rad (global); ``zeta`` the heading of the frame's Z;
    ``alpha``/``beta``/``theta``/``phi`` the model's angles (deg) in that frame;
    ``distance`` to the target (m); ``head`` and ``eyes`` the planned rotations (deg,
    relative to the body, toward the observer) with ``head_limit`` the head's allowance;
    ``stroke`` the right hand at the action's stroke point, 3D ``(x, h, y)``.
    """

    pos: tuple[float, float]
    heading: float
    zeta: float
    alpha: float
    beta: float
    theta: float
    phi: float
    distance: float
    e_vis: float
    e_neck: float
    e_action: float
    cost: float
    head: float
    eyes: float
    head_limit: float
    stroke: tuple[float, float, float]
    origin: str = "model"  # the pass that found it (PASSES): "fallback" is off the placement model

    @property
    def fallback(self) -> bool:
        """Off the placement model: no valid placement existed (:class:`PlacementSearch`)."""
        return self.origin == "fallback"


@dataclass(frozen=True)
class Weights:
    vis: float = W_VIS
    neck: float = W_NECK
    action: float = W_ACTION


@dataclass
class Plan:
    """The sorted valid placements (best first) and how many candidates failed, by reason.

    ``rejected`` and ``candidates`` count the model pass's frame orientations (§4);
    ``widened`` says the model gave no valid placement and the wide pass ran, ``fallback``
    that it gave none either and the list holds fallback placements (or is empty: nowhere
    the observer could be shown to). See :class:`PlacementSearch`.
    """

    ranked: list[Placement] = field(default_factory=list)
    rejected: dict[str, int] = field(default_factory=lambda: dict.fromkeys(REASONS, 0))
    candidates: int = 0
    widened: bool = False
    fallback: bool = False

    @property
    def best(self) -> Placement | None:
        return self.ranked[0] if self.ranked else None

    def after(self, p: Placement) -> Placement | None:
        """The next placement in the list after ``p`` (the alternative when motion synthesis fails, §4)."""
        for k, q in enumerate(self.ranked):
            if q is p:
                return self.ranked[k + 1] if k + 1 < len(self.ranked) else None
        return None


def first_frame(stage: Stage, target: tuple[float, float], observer: tuple[float, float], *, d_pref: float,
                default_zeta: float, radius: float) -> float:
    """The Z heading of the first candidate (§4).

    Z is orthogonal to the supporting table's closest edge; "if p_t lies
    between p_o and p_d⁰, the Z axis of the local placement coordinate frame
    is re-oriented towards p_o", so the initial placement faces the observer.
    "Between" is read as the target lying within the demonstrator's radius
    of the segment p_o–p_d⁰, strictly inside it.
    """
    zeta = stage.z_axis(target, default_zeta)
    alpha = float(local_angle(zeta, math.atan2(observer[1] - target[1], observer[0] - target[0])))
    beta, _, _ = placement_model_array(np.asarray([alpha]))
    d = zeta + math.pi - math.radians(float(beta[0]))
    p0 = (target[0] + d_pref * math.cos(d), target[1] + d_pref * math.sin(d))
    ox, oy = observer
    sx, sy = p0[0] - ox, p0[1] - oy
    ll = sx * sx + sy * sy
    if ll > 1e-12:
        t = ((target[0] - ox) * sx + (target[1] - oy) * sy) / ll
        if 0.0 < t < 1.0 and math.hypot(ox + t * sx - target[0], oy + t * sy - target[1]) < radius:
            zeta = math.atan2(oy - target[1], ox - target[0])
    return zeta


class PlacementSearch:
    """An exhaustive, resumable placement search (§4), spread over ticks by a work budget.

    ``advance(budget)`` evaluates the next ``budget`` frame orientations (each
    with its variants) and returns True once the search is complete;
    :attr:`plan` is then sorted. A budget in units of work, not time, keeps
    runs deterministic. ``start`` is where the demonstrator stands (for
    reachability); ``keep_clear`` discs ``(x, y, r)`` other demonstrators
    stand on.

    Three passes over the :data:`N_DIRECTIONS` frame orientations, each run
    only when the ones before found no valid placement (issue 24: a re-plan
    for an observer behind a pillar found none at ``d_pref`` while there were
    many farther out):

    ``model``     §4 as written: the model's candidate, perturbed (:data:`PERTURB`) only when
                  it collides; a direction keeps its first valid variant.
    ``wide``      pedvr's widening: every candidate that fails for any reason, hidden ones
                  included, is tried at distances ``d_pref`` × :data:`WIDE_FACTORS` and body
                  orientations θ + :data:`WIDE_TURNS`; a direction keeps its cheapest valid
                  variant. §4 allows that "any other desired factor could be added"; the
                  placements are valid by the same tests, only farther from ``d_pref``
                  (``e_action`` ranks them).
    ``fallback``  off the model: the body faces the observer turned by up to ±90°
                  (:data:`FALLBACK_TURNS`) toward the target instead of θ, the head may turn
                  :data:`HEAD_MAX` instead of φ's allowance, and the distance goes out to
                  :data:`FALLBACK_FAR` m. Collision, reachability, the action, visibility and eye
                  contact are still required: what is given up is the model's comfort, never
                  that the observer sees the demonstrator. :attr:`Plan.fallback` is then True
                  and every placement in the list has ``fallback`` set.

    A wide or fallback orientation carries several times the model pass's
    candidates, so a budget buys :data:`WIDE_SHARE` times fewer of them (at
    least one).
    """

    def __init__(self, stage: Stage, figure: Figure, action: Action, observer: Observer, *,
                 start: tuple[float, float], default_zeta: float = 0.0,
                 keep_clear: Sequence[tuple[float, float, float]] = (), weights: Weights = Weights()) -> None:
        self.stage = stage
        self.figure = figure
        self.action = action
        self.observer = observer
        self.weights = weights
        self.keep_clear = np.asarray(keep_clear, np.float64).reshape(-1, 3)
        self.zeta0 = first_frame(stage, action.target, observer.pos, d_pref=action.d_pref,
                                 default_zeta=default_zeta, radius=figure.radius)
        # 0, +1, -1, +2, -2, ... +36: every 5 degrees once, nearest the first frame first
        ks = [0]
        for k in range(1, N_DIRECTIONS // 2 + 1):
            ks.append(k)
            if k < N_DIRECTIONS // 2:
                ks.append(-k)
        self._zetas = self.zeta0 + np.radians(STEP_DEG * np.asarray(ks, np.float64))
        self._next = 0
        self._pass = 0  # index into PASSES
        tri = stage.mesh.locate(np.asarray([start], np.float64))[0]
        if tri < 0:
            snapped = stage.mesh.nearest_walkable(start)
            tri = stage.mesh.locate(np.asarray([snapped]))[0]
        self._component = int(stage.mesh.components[tri]) if tri >= 0 else -1
        self.plan = Plan()
        self._found: list[Placement] = []
        self._done = False

    @property
    def done(self) -> bool:
        return self._done

    def advance(self, budget: int = N_DIRECTIONS) -> bool:
        """Evaluate up to ``budget`` more frame orientations; True when the search is complete."""
        if self._done:
            return True
        n = max(1, int(budget)) if self._pass == 0 else max(1, int(budget) // WIDE_SHARE)
        chunk = self._zetas[self._next:self._next + n]
        self._next += len(chunk)
        if self._pass == 0:
            self.plan.candidates += len(chunk)
            self._evaluate_model(chunk)
        else:
            self._evaluate_relaxed(chunk, fallback=self._pass == 2)
        if self._next >= len(self._zetas):
            if self._found or self._pass == len(PASSES) - 1:
                self._found.sort(key=lambda p: (p.cost, p.pos[0], p.pos[1]))
                self.plan.ranked = self._found
                self._done = True
            else:  # nothing valid: the next, wider pass over the same orientations
                self._pass += 1
                self._next = 0
                self.plan.widened = True
                self.plan.fallback = self._pass == 2
        return self._done

    def run(self) -> Plan:
        """The whole search at once."""
        while not self.advance(len(self._zetas) * WIDE_SHARE):
            pass
        return self.plan

    # -- evaluation ---------------------------------------------------------------------------

    def _validity(self, pos: np.ndarray, heading: np.ndarray, limit: np.ndarray) -> tuple[
            np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The checks of §4 over candidates ``pos (n, 2)`` facing ``heading (n,)`` whose head may
        turn ``limit (n,)`` deg: ``(reason, e_vis, stroke, need)``; ``reason`` -1 where valid,
        else the index into :data:`REASONS` of the first check failed (they run in that order);
        ``need`` the signed rotation (deg, + toward pedvr's CCW) from the body to the observer."""
        n = len(pos)
        reason = self._placeable(pos)
        stroke = np.full((n, 3), np.nan)
        self._act(pos, heading, reason, stroke)
        e_vis = np.full(n, np.nan)
        self._visible(pos, reason, e_vis)
        need = self._eye_contact(pos, heading, limit, reason)
        return reason, e_vis, stroke, need

    def _placeable(self, pos: np.ndarray) -> np.ndarray:
        """``reason (n,)``: -1, or collision (static: off the mesh of the demonstrator's clearance;
        dynamic: the observer's personal space, other demonstrators), or unreachable."""
        obs = self.observer
        reason = np.full(len(pos), -1, np.int64)
        tri = self.stage.mesh.locate(pos)
        hit = tri < 0
        gap = np.hypot(pos[:, 0] - obs.pos[0], pos[:, 1] - obs.pos[1]) - self.figure.radius - obs.radius
        hit |= gap < OBSERVER_GAP
        for cx, cy, cr in self.keep_clear:
            hit |= np.hypot(pos[:, 0] - cx, pos[:, 1] - cy) < self.figure.radius + cr + KEEP_CLEAR_GAP
        reason[hit] = 0
        comp = np.where(tri >= 0, self.stage.mesh.components[np.maximum(tri, 0)], -2)
        reason[(reason < 0) & (comp != self._component)] = 1
        return reason

    def _act(self, pos: np.ndarray, heading: np.ndarray, reason: np.ndarray, stroke: np.ndarray) -> None:
        """The action from the candidates still valid (arm IK reach / pointing, hand clear of
        obstacles): fills ``stroke``, marks failures in ``reason``."""
        idx = np.flatnonzero(reason < 0)
        if idx.size:
            feasible, pts = stroke_points(self.stage, self.figure, self.action, pos[idx], heading[idx])
            stroke[idx] = pts
            reason[idx[~feasible]] = 2

    def _visible(self, pos: np.ndarray, reason: np.ndarray, e_vis: np.ndarray) -> None:
        """Head to head visibility, and the body out of the observer's view of the target, for the
        candidates still valid: fills ``e_vis``, marks failures in ``reason``."""
        idx = np.flatnonzero(reason < 0)
        if idx.size == 0:
            return
        obs = self.observer
        e = self.stage.occluded(pos[idx], self.figure.eye_height, np.repeat([obs.pos], len(idx), 0),
                                obs.eye_height)
        e_vis[idx] = e
        m = len(idx)
        seg_d = np.empty(m)
        kn.segment_distance_kernel(np.repeat([obs.pos], m, 0), np.repeat([self.action.target], m, 0),
                                   np.ascontiguousarray(pos[idx]), seg_d)
        reason[idx[(e > VIS_DISCARD) | (seg_d < self.figure.radius + VIEW_GAP)]] = 3

    def _eye_contact(self, pos: np.ndarray, heading: np.ndarray, limit: np.ndarray,
                     reason: np.ndarray) -> np.ndarray:
        """Eye contact within the head's allowance plus the eyes: marks failures in ``reason``;
        returns ``need``, the signed rotation (deg, + toward pedvr's CCW) to the observer."""
        obs = self.observer
        to_obs = np.arctan2(obs.pos[1] - pos[:, 1], obs.pos[0] - pos[:, 0])
        need = np.degrees((to_obs - heading + np.pi) % (2 * np.pi) - np.pi)
        reason[(reason < 0) & (np.abs(need) > limit + EYE_LIMIT)] = 4
        return need

    def _emit(self, cs: list[int], rows: list[int], *, pos: np.ndarray, heading: np.ndarray, zz: np.ndarray,
              alpha: np.ndarray, beta: np.ndarray, th: np.ndarray, ph: np.ndarray, e_vis: np.ndarray,
              stroke: np.ndarray, need: np.ndarray, limit: np.ndarray, origin: str) -> None:
        """Keep candidates ``cs`` (of frame orientations ``rows``) as placements, with their costs."""
        if not cs:
            return
        c = np.asarray(cs)
        tx, ty = self.action.target
        d = np.hypot(pos[c, 0] - tx, pos[c, 1] - ty)
        e_action = np.abs(self.action.d_pref - d)
        e_neck = np.abs(need[c])
        head = np.copysign(np.minimum(e_neck, limit[c]), need[c])
        w = self.weights
        cost = w.vis * e_vis[c] + w.neck * e_neck + w.action * e_action
        r = np.asarray(rows)
        columns = (pos[c, 0], pos[c, 1], heading[c], zz[c], alpha[r], beta[r], th[c], ph[c], d, e_vis[c],
                   e_neck, e_action, cost, head, need[c] - head, limit[c], *stroke[c].T)
        for px, py, hd, z, a, b, t, f, dd, ev, en, ea, co, he, ey, li, sx, sy, sz in zip(
                *(x.tolist() for x in columns), strict=True):
            self._found.append(Placement(
                pos=(px, py), heading=hd, zeta=z, alpha=a, beta=b, theta=t, phi=f, distance=dd, e_vis=ev,
                e_neck=en, e_action=ea, cost=co, head=he, eyes=ey, head_limit=li, stroke=(sx, sy, sz),
                origin=origin))

    def _model_angles(self, zetas: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        tx, ty = self.action.target
        obs = self.observer
        alpha = np.asarray(local_angle(zetas, math.atan2(obs.pos[1] - ty, obs.pos[0] - tx)))
        beta, theta, phi = placement_model_array(alpha)
        return alpha, beta, theta, phi

    def _ring(self, zetas: np.ndarray, beta: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """Positions ``(k, v, 2)``: for each frame orientation (along −Z turned by β) at each distance."""
        tx, ty = self.action.target
        d = (zetas + math.pi - np.radians(beta))[:, None]
        return np.stack([tx + dist[None, :] * np.cos(d), ty + dist[None, :] * np.sin(d)], -1)

    def _evaluate_model(self, zetas: np.ndarray) -> None:
        """§4's pass: the model's candidate per orientation, perturbed only when it collides."""
        alpha, beta, theta, phi = self._model_angles(zetas)
        k = len(zetas)
        variants = [(1.0, 0.0), *PERTURB]
        v = len(variants)
        factor = np.asarray([f for f, _ in variants])
        turn = np.asarray([o for _, o in variants])
        # (k, v) candidates: variant 0 is the model's own; the others are tried when it collides.
        pos = self._ring(zetas, beta, self.action.d_pref * factor).reshape(-1, 2)
        th = (theta[:, None] + turn[None, :]).reshape(-1)
        ph = np.repeat(phi, v)
        zz = np.repeat(zetas, v)
        heading = global_heading(zz, th)
        limit = np.clip(np.abs((ph - th + 180.0) % 360.0 - 180.0), HEAD_MIN, HEAD_MAX)
        reason, e_vis, stroke, need = self._validity(pos, heading, limit)
        r = reason.reshape(k, v)
        cs: list[int] = []
        rows: list[int] = []
        for i in range(k):
            row = r[i]
            choice = 0 if row[0] < 0 else -1
            if row[0] == 0:  # collides: try the perturbations in order
                for j in range(1, v):
                    if row[j] < 0:
                        choice = j
                        break
            if choice < 0:
                # the furthest check any variant got to (checks run in the order of REASONS)
                self.plan.rejected[REASONS[int(row.max()) if row[0] == 0 else int(row[0])]] += 1
                continue
            cs.append(i * v + choice)
            rows.append(i)
        self._emit(cs, rows, pos=pos, heading=heading, zz=zz, alpha=alpha, beta=beta, th=th, ph=ph,
                   e_vis=e_vis, stroke=stroke, need=need, limit=limit, origin=PASSES[0])

    def _evaluate_relaxed(self, zetas: np.ndarray, *, fallback: bool) -> None:
        """The wide pass (model orientations, every failing candidate perturbed) or the fallback
        (the body facing the observer, farther rings); each orientation keeps its cheapest valid
        candidate."""
        alpha, beta, theta, phi = self._model_angles(zetas)
        k = len(zetas)
        d_pref = self.action.d_pref
        dists = d_pref * np.asarray(WIDE_FACTORS)
        if fallback:
            far = np.arange(math.ceil(dists.max() / FALLBACK_RING) * FALLBACK_RING, FALLBACK_FAR + 1e-9,
                            FALLBACK_RING)
            dists = np.concatenate([dists, far[far > dists.max() + 1e-9]])
            turns = np.asarray(FALLBACK_TURNS)
        else:
            turns = np.asarray(WIDE_TURNS)
        nd, nt = len(dists), len(turns)
        v = nd * nt
        # where the body stands decides collision, reachability and visibility (the cheap checks,
        # here first: the valid set is the same); how it faces, the action and eye contact
        ring = np.ascontiguousarray(self._ring(zetas, beta, dists).reshape(-1, 2))  # (k, nd) order
        where = self._placeable(ring)
        e_ring = np.full(len(ring), np.nan)
        self._visible(ring, where, e_ring)
        pos = np.repeat(ring, nt, axis=0)  # (k, nd, nt) order
        zz = np.repeat(zetas, v)
        if fallback:
            obs = self.observer.pos
            to_obs = np.arctan2(obs[1] - pos[:, 1], obs[0] - pos[:, 0])
            heading = to_obs + np.radians(np.tile(turns, k * nd))
            th = np.degrees(zz - heading)  # the body's local angle from Z (module convention)
            limit = np.full(k * v, HEAD_MAX)
        else:
            th = (theta[:, None, None] + np.zeros((1, nd, 1)) + turns[None, None, :]).reshape(-1)
            heading = global_heading(zz, th)
            ph = np.repeat(phi, v)
            limit = np.clip(np.abs((ph - th + 180.0) % 360.0 - 180.0), HEAD_MIN, HEAD_MAX)
        reason = np.repeat(where, nt)
        e_vis = np.repeat(e_ring, nt)
        stroke = np.full((k * v, 3), np.nan)
        self._act(pos, heading, reason, stroke)
        need = self._eye_contact(pos, heading, limit, reason)
        w = self.weights
        tx, ty = self.action.target
        cost = (w.vis * e_vis + w.neck * np.abs(need)
                + w.action * np.abs(d_pref - np.hypot(pos[:, 0] - tx, pos[:, 1] - ty)))
        cost = np.where(reason < 0, cost, np.inf).reshape(k, v)
        cs: list[int] = []
        rows: list[int] = []
        for i in range(k):
            j = int(np.argmin(cost[i]))  # the first of equal costs: nearest d_pref, then the model's θ
            if not math.isfinite(cost[i, j]):
                continue
            cs.append(i * v + j)
            rows.append(i)
        self._emit(cs, rows, pos=pos, heading=heading, zz=zz, alpha=alpha, beta=beta,
                   th=np.asarray(wrap_deg(th)), ph=np.repeat(phi, v), e_vis=e_vis, stroke=stroke, need=need,
                   limit=limit, origin=PASSES[2] if fallback else PASSES[1])


def plan_placement(stage: Stage, figure: Figure, action: Action, observer: Observer, *,
                   start: tuple[float, float], default_zeta: float = 0.0,
                   keep_clear: Sequence[tuple[float, float, float]] = (),
                   weights: Weights = Weights()) -> Plan:
    """The complete search (:class:`PlacementSearch`) in one call."""
    return PlacementSearch(stage, figure, action, observer, start=start, default_zeta=default_zeta,
                           keep_clear=keep_clear, weights=weights).run()


def score(stage: Stage, figure: Figure, action: Action, observer: Observer, *, pos: tuple[float, float],
          heading: float, weights: Weights = Weights(), head_limit: float = HEAD_MAX) -> float:
    """The ranking cost of standing at ``pos`` facing ``heading`` for ``observer`` (inf if invalid now).

    What the re-planning hysteresis compares a new plan against: the current
    placement, re-scored for where the observer is now (its action and path
    were valid when chosen; the observer's move can only change visibility,
    the neck rotation and the personal-space gap).
    """
    gap = math.hypot(pos[0] - observer.pos[0], pos[1] - observer.pos[1]) - figure.radius - observer.radius
    if gap < OBSERVER_GAP - 0.1:
        return math.inf
    e_vis = float(stage.occluded(np.asarray([pos]), figure.eye_height, np.asarray([observer.pos]),
                                 observer.eye_height)[0])
    if e_vis > VIS_DISCARD:
        return math.inf
    to_obs = math.atan2(observer.pos[1] - pos[1], observer.pos[0] - pos[0])
    need = abs(math.degrees((to_obs - heading + math.pi) % (2 * math.pi) - math.pi))
    if need > head_limit + EYE_LIMIT:
        return math.inf
    d = math.hypot(pos[0] - action.target[0], pos[1] - action.target[1])
    return weights.vis * e_vis + weights.neck * need + weights.action * abs(action.d_pref - d)
