"""Body footprints: discs that narrow to ellipses when people turn their shoulders.

A walking person is about a shoulder width across (``2 r``, the disc of
PedVR §3.1) and about 0.26 m deep front to back. Crowd models keep the disc;
pedvr keeps it too, except where two people must squeeze past each other:
there people turn their shoulders so that the narrow, front-to-back side of
the body faces the other person (PedVR §7, future work; Best et al. 2016 on
footprints). The model (pedvr's choice; the papers give no formula):

* Each agent has a turn amount ``τ ∈ [0, 1]`` and a torso facing ``ψ``
  (rad, world frame). Its footprint is the ellipse with semi-axis ``a = r``
  along the shoulders (``s = (-sin ψ, cos ψ)``) and ``b = r (1 - τ (1 -
  DEPTH_RATIO))`` front to back (``f = (cos ψ, sin ψ)``). With ``τ = 0`` it is
  the disc of radius ``r``, whatever ``ψ``.
* Distances between footprints use the support function along the line of
  centres, ``h(d) = sqrt(a² (d·s)² + b² (d·f)²)``: two bodies touch when
  their centre distance is ``h_i(d) + h_j(-d)``, a body touches a wall when
  its centre is ``h(n)`` from it (``n`` the direction from the wall to the
  centre). For two ellipses this is the usual first-order approximation (exact
  when a principal axis lies along the line of centres, the case of two people
  passing shoulder to shoulder); ORCA, the contact pass and the overlap
  metrics all use it, so what is steered is what is measured.
* Who turns: an agent that passes someone (relative speed above
  ``PASS_SPEED``) whose disc is within ``SQUEEZE_GAP`` of its own, or that
  the user encounter model (:mod:`pedvr.crowd.encounter`) finds short of room
  beside the user, turns toward ``τ = 1`` at ``TURN_RATE`` per second and
  untwists at the same rate once nobody is that close. The torso faces across
  the line along which the two pass (perpendicular to their relative velocity),
  toward the other person, as people squeezing past each other mostly do.

``DEPTH_RATIO = 0.52``: a chest depth of 0.26 m beside a 0.50 m shoulder width
(adult anthropometry: chest depth 0.23-0.28 m, biacromial width 0.36-0.46 m
plus the arms). The user is always a disc: pedvr cannot turn the person.

The walking body (coupled mode, issue 26): a person is not as deep as wide even when not
squeezing past anyone, and follows others closer than a disc of shoulder width allows. In
the coupled condition an agent that does not squeeze has the turn ``walk_turn`` (from
``[steering] depth_ratio``, the half depth over the radius: ``b = depth_ratio · r``) with its
torso along its heading: an ellipse a shoulder width across and ``2 b`` front to back, so two
people in line come as close as ``2 b`` centre to centre (0.72 · 0.25 m: 0.36 m, the length a
pedestrian standing in a line takes up, Seyfried et al. 2005, J. Stat. Mech. P10002). Its
torso follows the heading at ``TORSO_RATE`` (taking the nearer of the two facings of the
same ellipse). Squeezing turns it further, to ``τ = 1``, as above. The decoupled condition
keeps ``walk_turn = 0``: the paper's discs.

A pushed perambulator (Huang & Terzopoulos §4.6: "a longer footprint for
steering"; the paper gives no shape, this is pedvr's choice) makes the pusher
and the pram one rigid footprint: the ellipse with its long semi-axis ``L``
along the heading, its short one the agent's ``radius`` across, centred
``ahead`` of the body's position (:func:`enclosing_ellipse` picks the centre
and the shortest ``L`` that hold the pusher's back and shoulders and the
pram's basket, handle and wheels, :data:`pedvr.body.carry.PRAM_HULL`). Why an
ellipse ahead and not a larger disc: a disc round pusher and pram is 1.4 m
across and does not fit a 1.3 m doorway, while the ellipse is only as wide as
the agent's disc, which is what steering through a doorway needs; and it is the
ellipse the kernels already steer, measure and push apart, written in their
terms (:func:`footprints`): the kernels' ``a`` (the bounding semi-axis, which
their early outs rely on) is ``L`` along the heading, their ``b`` the radius
across, their centre the ellipse's. Such a footprint is rigid: it never turns
its shoulders, and moving door leaves see it as it is (``rigid``), not as its
bounding disc, so a pram fits through a door that a bounding disc would not.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from pedvr.crowd.neighbors import cell_span, obstacle_neighbors_of
from pedvr.kernels import row_njit, wrap_pi
from pedvr.scene.config import TURNED_DEPTH_RATIO

DEPTH_RATIO = TURNED_DEPTH_RATIO  # front-to-back half depth / shoulder half width, turned
SQUEEZE_GAP = 0.15  # m: a passing neighbour's disc this close (surface to surface) makes the agent turn
PASS_SPEED = 0.2  # m/s: relative speed above which a close neighbour is passing (not queueing)
TURN_RATE = 2.5  # 1/s: τ changes at most this much per second (0.4 s to turn fully)
TORSO_RATE = 4.0  # rad/s: how fast a turned torso re-orients to a new passing line


@njit(cache=True, inline="always")
def support(a, b, fx, fy, dx, dy):
    """Support radius of the ellipse (``a`` along the shoulders, ``b`` along the facing
    ``(fx, fy)``) in the unit direction ``(dx, dy)``."""
    along_f = dx * fx + dy * fy
    along_s = -dx * fy + dy * fx
    return math.sqrt(a * a * along_s * along_s + b * b * along_f * along_f)


@njit(cache=True, inline="always")
def depth_of(radius, turn):
    """Front-to-back half depth ``b`` for a turn amount ``τ``."""
    return radius * (1.0 - turn * (1.0 - DEPTH_RATIO))


def turn_for(depth_ratio: float) -> float:
    """The turn ``τ`` whose half depth is ``depth_ratio`` times the radius (the inverse of
    :func:`depth_of`): 0 for the disc, 1 for :data:`DEPTH_RATIO`."""
    return (1.0 - depth_ratio) / (1.0 - DEPTH_RATIO)


@njit(cache=True, inline="always")
def _toward(torso, fx, fy, turn, dt):
    """The torso facing one step toward ``(fx, fy)`` or its opposite, whichever is nearer (the
    ellipse is the same for both: at most a quarter turn), at ``TORSO_RATE``; at once for a disc
    (``turn <= 0``), so the footprint never jumps (a jump toward a wall would leave the agent
    inside it)."""
    want = math.atan2(fy, fx)
    delta = wrap_pi(want - torso)
    if delta > 0.5 * math.pi:
        delta -= math.pi
    elif delta < -0.5 * math.pi:
        delta += math.pi
    if turn <= 0.0:
        return torso + delta
    lim = TORSO_RATE * dt
    return torso + min(max(delta, -lim), lim)


@njit(cache=True)  # O(N) and cheap: a parallel region would cost more than it saves (pedvr.kernels)
def turn_kernel(pos, vel, radius, is_user, turn, torso, heading, walk_turn, nbr_idx, nbr_count,
                short_of_room, room_dir, narrow_dir, wall_dist, dt, out_turn, out_torso):
    """New ``τ`` and torso facing per row (compute, then the caller commits).

    ``short_of_room[i]`` (from the user encounter) makes the agent turn with its torso
    facing ``room_dir[i]`` (a unit vector across the passing line) even before it is
    that close; ``narrow_dir[i]`` (nonzero: :func:`narrow_kernel`), entering a passage
    between walls narrower than its shoulders, likewise, and before any neighbour: there the
    walls decide which way the shoulders lie. A turned agent untwists only
    where its disc fits: no neighbour's disc within ``SQUEEZE_GAP`` and no wall closer
    than its radius (``wall_dist[i]``, the distance to the nearest obstacle edge);
    otherwise it holds its turn. It untwists to
    ``walk_turn`` (coupled: the walking body's ellipse, its torso following ``heading``;
    0: the disc). User rows never turn.
    """
    for i in range(pos.shape[0]):
        out_turn[i] = 0.0
        out_torso[i] = torso[i]
        if is_user[i]:
            continue
        best = 1e30
        fx = 0.0
        fy = 0.0
        found = False
        px = pos[i, 0]
        py = pos[i, 1]
        crowded = wall_dist[i] < radius[i]
        walls = narrow_dir[i, 0] != 0.0 or narrow_dir[i, 1] != 0.0
        if walls:
            # a passage narrower than the shoulders: its walls decide the facing, whoever is near
            fx = narrow_dir[i, 0]
            fy = narrow_dir[i, 1]
            found = True
            crowded = True
        for q in range(nbr_count[i]):
            j = nbr_idx[i, q]
            dx = pos[j, 0] - px
            dy = pos[j, 1] - py
            d = math.sqrt(dx * dx + dy * dy)
            gap = d - radius[i] - radius[j]
            if gap < SQUEEZE_GAP:
                crowded = True
            if walls or gap >= SQUEEZE_GAP or gap >= best or d < 1e-9:
                continue
            rvx = vel[i, 0] - vel[j, 0]
            rvy = vel[i, 1] - vel[j, 1]
            rs = math.sqrt(rvx * rvx + rvy * rvy)
            if rs < PASS_SPEED:
                continue
            # Face across the passing line (perpendicular to the relative velocity),
            # toward the other person.
            nx = -rvy / rs
            ny = rvx / rs
            if nx * dx + ny * dy < 0.0:
                nx = -nx
                ny = -ny
            best = gap
            fx = nx
            fy = ny
            found = True
        if not found and short_of_room[i]:
            fx = room_dir[i, 0]
            fy = room_dir[i, 1]
            found = True
        target = 1.0 if found else (max(turn[i], walk_turn) if crowded else walk_turn)
        step = TURN_RATE * dt
        out_turn[i] = min(max(target, turn[i] - step), turn[i] + step)
        if found:
            out_torso[i] = _toward(torso[i], fx, fy, turn[i], dt)
        elif walk_turn > 0.0 and turn[i] <= walk_turn:
            # walking, not squeezing: the body's depth along its heading
            out_torso[i] = _toward(torso[i], math.cos(heading[i]), math.sin(heading[i]), turn[i], dt)


NARROW_MARGIN = 0.05  # m: a passage narrower than the shoulders plus this is squeezed through turned
NARROW_LOOKAHEAD = 0.5  # m: the passage is looked for this far ahead too (turning takes 0.4 s)


@njit(cache=True, inline="always")
def _passage(px, py, ex, ey, reach, vertices, nxt, n_static, origin, cell, nx, ny, cell_start,
             cell_edges, edge_cells):
    """``(left, right, inside, nx, ny)``: the distances from ``p`` to the nearest static obstacle
    edge on each side of the way ``e`` (inf where none within ``reach``), whether ``p`` lies
    inside an obstacle (behind its nearest edge: RVO2's edges have the free side on their
    right), and the unit direction from ``p`` to the nearest edge point ((0, 0): none)."""
    left = math.inf
    right = math.inf
    nearest = math.inf
    inside = False
    nx_ = 0.0
    ny_ = 0.0
    qx0, qx1, qy0, qy1 = cell_span(px, py, reach, origin, cell, nx, ny)
    for gy in range(qy0, qy1 + 1):
        for gx in range(qx0, qx1 + 1):
            c = gy * nx + gx
            for q in range(cell_start[c], cell_start[c + 1]):
                k = cell_edges[q]
                if k >= n_static or gx != max(edge_cells[k, 0], qx0) or gy != max(edge_cells[k, 1], qy0):
                    continue
                ax = vertices[k, 0]
                ay = vertices[k, 1]
                bx = vertices[nxt[k], 0]
                by = vertices[nxt[k], 1]
                wx = bx - ax
                wy = by - ay
                ll = wx * wx + wy * wy
                t = 0.0 if ll <= 0.0 else min(max(((px - ax) * wx + (py - ay) * wy) / ll, 0.0), 1.0)
                dx = ax + t * wx - px
                dy = ay + t * wy - py
                d = math.sqrt(dx * dx + dy * dy)
                if d >= reach:
                    continue
                if d < nearest:
                    nearest = d
                    inside = (ax - px) * wy - (ay - py) * wx > 0.0  # p left of a -> b
                    if d > 1e-9:
                        nx_ = dx / d
                        ny_ = dy / d
                if ex * dy - ey * dx > 0.0:
                    left = min(left, d)
                else:
                    right = min(right, d)
    return left, right, inside, nx_, ny_


@njit(cache=True)  # O(N) and cheap: a parallel region would cost more than it saves (pedvr.kernels)
def narrow_kernel(pos, pref_vel, radius, is_user, vertices, nxt, n_static, origin, cell, nx, ny,
                  cell_start, cell_edges, edge_cells, out_dir):
    """``out_dir[i]``: a unit torso facing across the passage (toward its nearest wall, so the
    shoulders lie along it) where agent ``i`` is about to squeeze through a passage between
    walls narrower than its shoulders plus ``NARROW_MARGIN``, at its position or
    ``NARROW_LOOKAHEAD`` ahead along its preferred velocity;
    ``(0, 0)`` elsewhere (issue 26: real people pass 0.5 m, turned). A look-ahead point inside
    an obstacle (the agent walks at a wall) does not count."""
    for i in range(pos.shape[0]):
        out_dir[i, 0] = 0.0
        out_dir[i, 1] = 0.0
        vx = pref_vel[i, 0]
        vy = pref_vel[i, 1]
        v = math.sqrt(vx * vx + vy * vy)
        if is_user[i] or v < 1e-6:
            continue
        ex = vx / v
        ey = vy / v
        reach = radius[i] + NARROW_MARGIN
        for ahead in (0.0, NARROW_LOOKAHEAD):
            left, right, inside, wx, wy = _passage(pos[i, 0] + ahead * ex, pos[i, 1] + ahead * ey, ex, ey,
                                                   reach, vertices, nxt, n_static, origin, cell, nx, ny,
                                                   cell_start, cell_edges, edge_cells)
            if not inside and left + right < 2.0 * reach:
                # the chest toward the nearest wall: the shoulders lie along the passage, whichever
                # way the agent comes at it (across its own way would turn them askew in the mouth)
                if wx == 0.0 and wy == 0.0:
                    wx = -ey
                    wy = ex
                out_dir[i, 0] = wx
                out_dir[i, 1] = wy
                break


@njit(cache=True)
def wall_distance_kernel(pos, rows, radius, vertices, nxt, origin, cell, nx, ny, cell_start,
                         cell_edges, edge_cells, out):
    """``out[i]``: distance from each of ``rows`` to its nearest obstacle edge when one is
    within its radius (left as it is otherwise). For the turned agents only: they are few."""
    cap = 16
    idx = np.empty(cap, np.int64)
    dsq = np.empty(cap)
    for k in range(rows.shape[0]):
        i = rows[k]
        reach = radius[i]
        while True:
            cnt = obstacle_neighbors_of(pos[i, 0], pos[i, 1], reach * reach, vertices, nxt, origin,
                                        cell, nx, ny, cell_start, cell_edges, edge_cells, idx, dsq)
            if cnt <= cap:
                break
            cap = cnt
            idx = np.empty(cap, np.int64)
            dsq = np.empty(cap)
        if cnt > 0:
            out[i] = math.sqrt(dsq[0])


SHOULDER_TWIST_LIMIT = math.radians(60.0)  # the most the chest turns against the pelvis when drawn


def shoulder_twist(turn: np.ndarray, torso: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """The body's upper-torso yaw relative to the pelvis (rad) for turned footprints: the
    shortest twist that brings the chest to face ``torso`` or its opposite (the footprint
    is the same either way), scaled by ``τ`` and capped at 60° (people squeezing past
    twist the chest about that much and side-step the rest). ``(N,)`` arrays."""
    f64 = np.float64
    out = np.empty(np.shape(turn)[0])
    _twist_kernel(np.ascontiguousarray(turn, f64), np.ascontiguousarray(torso, f64),
                  np.ascontiguousarray(heading, f64), out)
    return out


@njit(cache=True)
def _twist_kernel(turn, torso, heading, out):  # type: ignore[no-untyped-def]
    """:func:`shoulder_twist` in one pass: the bytes of the numpy expressions it replaced (numpy's
    float remainder is CPython's, as numba's; ``np.clip`` keeps a NaN), without their six
    temporary arrays (issue 27: 34 µs a step at 1000 agents, 7 µs this way)."""
    for i in range(turn.shape[0]):
        delta = wrap_pi(torso[i] - heading[i])
        if delta > 0.5 * math.pi:
            delta = delta - math.pi
        elif delta < -0.5 * math.pi:
            delta = delta + math.pi
        v = turn[i] * delta
        if v < -SHOULDER_TWIST_LIMIT:
            v = -SHOULDER_TWIST_LIMIT
        elif v > SHOULDER_TWIST_LIMIT:
            v = SHOULDER_TWIST_LIMIT
        out[i] = v


def footprint_arrays(radius: np.ndarray, turn: np.ndarray,
                     torso: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``depth (N,)`` (the ellipse's ``b``, m) and ``facing (N, 2)`` (unit ``f``) for the kernels."""
    depth = radius * (1.0 - turn * (1.0 - DEPTH_RATIO))
    facing = np.empty((np.shape(torso)[0], 2))
    np.cos(torso, out=facing[:, 0])
    np.sin(torso, out=facing[:, 1])
    return np.ascontiguousarray(depth), facing


class Footprints(NamedTuple):
    """Every row's footprint in the kernels' terms: the ellipse centred at ``centre (N, 2)`` m
    with semi-axis ``radius (N,)`` along ``(-facing_y, facing_x)`` (the bounding one) and
    ``depth (N,)`` along ``facing (N, 2)``; ``rigid (N,)`` the carried-object footprints."""

    centre: np.ndarray
    radius: np.ndarray
    depth: np.ndarray
    facing: np.ndarray
    rigid: np.ndarray


def footprints(pos: np.ndarray, radius: np.ndarray, turn: np.ndarray, torso: np.ndarray,
               heading: np.ndarray, ahead: np.ndarray, length: np.ndarray) -> Footprints:
    """The footprints of a crowd's rows (see the module docstring): discs, turned ellipses, and
    for rows with ``length > 0`` the ellipse ``length`` long along the heading and ``radius``
    across, centred ``ahead`` of ``pos``. Contiguous float64 arrays, ready for the kernels: one
    pass of :func:`row_footprint` over the rows (every step builds them, some phases twice; the
    numpy expressions this replaced made a dozen temporary arrays)."""
    n = np.shape(pos)[0]
    out = Footprints(np.empty((n, 2)), np.empty(n), np.empty(n), np.empty((n, 2)), np.empty(n, np.bool_))
    f64 = np.float64
    _footprints_kernel(np.ascontiguousarray(pos, f64).reshape(-1, 2), np.ascontiguousarray(radius, f64),
                       np.ascontiguousarray(turn, f64), np.ascontiguousarray(torso, f64),
                       np.ascontiguousarray(heading, f64), np.ascontiguousarray(ahead, f64),
                       np.ascontiguousarray(length, f64), *out)
    return out


@row_njit()
def _footprints_kernel(pos, radius, turn, torso, heading, ahead, length, centre, a, depth, facing, rigid):  # type: ignore[no-untyped-def]
    for i in range(pos.shape[0]):
        cx, cy, ai, bi, fx, fy = row_footprint(pos[i, 0], pos[i, 1], radius[i], turn[i], torso[i], heading[i],
                                               ahead[i], length[i])
        centre[i, 0] = cx
        centre[i, 1] = cy
        a[i] = ai
        depth[i] = bi
        facing[i, 0] = fx
        facing[i, 1] = fy
        rigid[i] = length[i] > 0.0


@njit(cache=True, inline="always")
def row_footprint(x, y, radius, turn, torso, heading, ahead, length):  # type: ignore[no-untyped-def]
    """One row of :func:`footprints`, for kernels that need a few rows' footprints and not the
    arrays: ``(cx, cy, a, b, fx, fy)``, the centre, the semi-axis ``a`` across ``(fx, fy)`` and
    ``b`` along it, for a body at ``(x, y)``."""
    if length > 0.0:  # a carried object's ellipse, centred ahead, long along the heading
        c, s = math.cos(heading), math.sin(heading)
        return x + ahead * c, y + ahead * s, length, radius, -s, c
    return x, y, radius, depth_of(radius, turn), math.cos(torso), math.sin(torso)


def positions_of(centre: np.ndarray, heading: np.ndarray, ahead: np.ndarray) -> np.ndarray:
    """The bodies' positions ``(N, 2)`` for footprint centres ``centre`` (the inverse of the
    offset in :func:`footprints`: rows with ``ahead`` 0 are their centres)."""
    h = np.asarray(heading, np.float64)
    return centre - np.asarray(ahead, np.float64)[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)


def enclosing_ellipse(radius: float, hull: np.ndarray) -> tuple[float, float]:
    """``(ahead, length)``: the ellipse with semi-axis ``radius`` across and the shortest
    ``length`` along the heading, centred ``ahead`` of the body, that holds every point of
    ``hull (P, 2)`` (body frame, m: forward, across). Centres are tried every millimetre
    between the hull's back and front. ``radius`` must exceed every point's ``|across|``:
    a ValueError says by how much it does not."""
    hull = np.asarray(hull, np.float64).reshape(-1, 2)
    widest = float(np.abs(hull[:, 1]).max())
    if not radius > widest:
        raise ValueError(f"radius {radius}: must be > {widest} (the carried object's half width)")
    k = np.sqrt(1.0 - (hull[:, 1] / radius) ** 2)
    centres = np.arange(hull[:, 0].min(), hull[:, 0].max() + 1e-3, 1e-3)
    need = (np.abs(hull[None, :, 0] - centres[:, None]) / k[None, :]).max(axis=1)
    best = int(np.argmin(need))
    return float(centres[best]), float(max(need[best], radius))


COVER_DISCS = 5  # discs along a rigid footprint's long axis that hold it (door controller and ORCA)
_COVER_SAMPLES = 361  # outline samples (half an ellipse) a covering disc's radius is measured on
# The ORCA kernels' flags (pedvr.crowd.orca), so that their lines and the door controller's discs agree.
_COVER_FM = {"nsz", "arcp", "contract", "afn"}


@row_njit(fastmath=_COVER_FM)
def cover_radius(a: float, b: float, x: float, lo: float, hi: float) -> float:
    """The radius of the disc centred ``x`` along the long axis of an ellipse (semi-axes ``a``
    along, ``b`` across) that holds the part of its outline between ``lo`` and ``hi`` along the
    axis, measured on 361 samples of the half outline, plus 2 mm for the outline between samples."""
    best = 0.0
    for k in range(_COVER_SAMPLES):
        t = math.pi * k / (_COVER_SAMPLES - 1)
        ox = a * math.cos(t)
        oy = b * math.sin(t)
        if lo <= ox <= hi:
            d = math.sqrt((ox - x) * (ox - x) + oy * oy)
            if d > best:
                best = d
    return best + 2e-3


@row_njit(fastmath=_COVER_FM)
def cover_disc(a: float, b: float, k: int) -> tuple[float, float]:
    """Covering disc ``k`` of :data:`COVER_DISCS` of an ellipse (semi-axes ``a`` along, ``b``
    across): its centre's offset along the long axis (evenly from one end's ``-(a - b)`` to the
    other's) and its radius, as large as the farthest point of the outline nearest to it along
    the axis (:func:`cover_radius`). The union holds the whole ellipse (every chord across the
    axis lies in the triangle of its disc's centre and the chord's ends)."""
    half = max(a - b, 0.0)
    gap = half / (COVER_DISCS - 1)
    x = -half + 2.0 * gap * k
    lo = -a if k == 0 else x - gap
    hi = a if k == COVER_DISCS - 1 else x + gap
    return x, cover_radius(a, b, x, lo, hi)


def covering_discs(fp: Footprints, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Discs whose union holds the rigid footprints of ``rows`` (:func:`cover_disc`), for the door
    controller, which sees bodies as discs (:mod:`pedvr.etiquette.doors`); ORCA makes a rigid
    footprint's obstacle lines from the same discs (``orca.rigid_obstacle_lines``). Returns ``pos
    (R·K, 2)``, ``radius (R·K,)`` and each disc's row ``owner (R·K,)``."""
    rows = np.asarray(rows, np.int64)
    k = COVER_DISCS
    pos = np.zeros((len(rows) * k, 2))
    rad = np.zeros(len(rows) * k)
    for n, i in enumerate(rows.tolist()):
        a, b = float(fp.radius[i]), float(fp.depth[i])
        u = np.array([-fp.facing[i, 1], fp.facing[i, 0]])  # the long axis (kernels' a)
        for j in range(k):
            x, rad[n * k + j] = cover_disc(a, b, j)
            pos[n * k + j] = fp.centre[i] + x * u
    return pos, rad, np.repeat(rows, k)
