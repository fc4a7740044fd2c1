"""ORCA as numba kernels: a port of RVO2's ``Agent::computeNewVelocity``.

Optimal Reciprocal Collision Avoidance (van den Berg, Guy, Lin, Manocha 2011,
"Reciprocal n-body collision avoidance"): each agent turns every neighbour
(and every nearby obstacle edge) into a half-plane of permitted velocities, an
*ORCA line*, and picks the velocity closest to its preferred one inside all of
them and inside the max-speed disc (``linear_program2``). When that is
infeasible it minimises the largest violation of the agent lines while keeping
the hard lines (``linear_program3``, paper §5.3 "dense situations").

Lines are rows ``(point_x, point_y, dir_x, dir_y)`` of a float64 array; the
permitted side is the left of ``direction`` (RVO2's convention). Everything is
float64 where RVO2 uses float32; results agree to ~1e-5 m/s except where a
float32 comparison flips a branch.

Responsibility (DESIGN.md "crowd")
    For a neighbour pair the ORCA line passes through ``v_i + share * u``.
    Between virtual agents ``share = 0.5`` (reciprocity). Toward the user, ORCA's
    per-step share would be void: against a partner that does not reciprocate, a
    share ρ of the remaining correction every step converges to all of it within a
    fraction of a second. So the share ρ is taken over the encounter, in the
    preferred velocity (:mod:`pedvr.crowd.encounter`), and the user's line here is
    only the late safety step: share 1, the short ``user_horizon``, contact radii.
    User rows are never steered: their output velocity is their input one.

Footprints
    Bodies are discs (:mod:`pedvr.crowd.footprint`), except agents that turned their
    shoulders to squeeze past someone and pram pushers. Between agents, a pair's combined
    radius is the two bodies' support radii along the line of centres. Toward the user (the
    late safety step, which the agent alone must meet) a pair that is not two discs gets the
    velocity obstacle of the two footprints' Minkowski sum instead: each line is a support
    line of it (:func:`shaped_agent_line`), in contact the support along the line of
    centres, as the contact pass measures.

Coupled mode (PedVR §4.1: the body's motion limits in the same program)
    With ``coupled`` the hard prefix of the program holds, after the obstacle
    lines, these motion-limit lines built from the current velocity ``v``
    (speed ``s``), heading unit ``h`` and time step ``dt``:

    (a) acceleration: a 16-gon inscribed in the region made of a forward
        half-ellipse (semi-axes ``max_accel*dt`` along the motion direction
        ``f``, ``L`` across) and a backward half-ellipse (``max_decel*dt``
        along ``-f``, ``L`` across), centred on ``v``, with
        ``L = min(max_accel, max_decel)*dt``. (Two half-discs of different
        radii would not be convex; the half-ellipses meet smoothly.) ``f`` is
        ``v/s``, or the heading when ``s < STOPPED_SPEED``.
    (b) turn rate: ``|(v' - v)·f⊥| <= max(s*ω(s), max_accel)*dt`` with
        ``ω`` linear from ``LIMIT_TURN_STANDING`` at rest to
        ``LIMIT_TURN_WALKING`` at ``pref_speed`` (constant above). The floor
        ``max_accel`` means the pair never binds tighter than (a) at low
        speed, where the direction of motion is free to change (one stops and
        sets off elsewhere); at walking speed it caps the centripetal change.
        Omitted when ``s < STOPPED_SPEED``.
    (c) heading-relative: backward ``v'·h >= -LIMIT_BACKWARD`` and sideways
        ``|v'·h⊥| <= LIMIT_SIDEWAYS + k * (v'·h)`` with ``k = tan 30°``
        (capped at ``LIMIT_SIDEWAYS / LIMIT_BACKWARD`` so that walking straight
        backwards stays feasible). The slack grows with forward speed because
        the body's heading lags the velocity while turning: at 1.3 m/s forward
        the velocity may point about 54° off the heading, at 0.6 m/s a pure
        side-step is allowed. Both sides stay linear (a cone with apex behind
        the agent), so this is still one LP.

What is relaxed first when the program is infeasible
    1. The agent (neighbour) lines are soft: ``linear_program3`` minimises
       their largest violation, keeping obstacle and motion-limit lines hard.
       Coupled, with ``[steering] dense_slack`` > 0, the agent then takes the
       velocity nearest its preferred one among those that violate no agent line
       by more than that slack beyond the least violation (:func:`toward_preferred`).
    2. If the hard prefix itself is infeasible (e.g. a wall ahead closer than
       the braking distance, or the body's heading jumped so ``v`` violates
       (c)), the heading-relative lines (c) are dropped first.
    3. If obstacles plus (a), (b) are still infeasible (a body pushed toward a
       wall faster than it can brake before ORCA's obstacle horizon), the
       obstacle lines join the agent lines as soft ones: the body brakes as
       hard as (a), (b) allow toward the velocity that violates them least,
       and the contact pass (:mod:`pedvr.crowd.contact`) keeps it out of the
       wall. (Since issue 26 a body's velocity is its actual motion, pushes
       included, so this happens: about twice in 14 400 agent-steps of
       ``bidirectional_flow``; dropping every limit there made the body's
       velocity jump by 30 m/s² and more.)
    4. If (a), (b) alone are infeasible (a velocity above max speed, which the
       simulation never hands in), all motion-limit lines are dropped and plain
       ORCA (RVO2's behaviour) is solved.
    5. Coupled, wherever some line still cannot be kept, the user's line (the safety step)
       joins the hard ones if they allow it; if even they do not (the user walks into an agent
       pressed against a wall or a crowd faster than its limits let it step away), the user's
       line alone is hard for that step: the agent steps aside beyond its limits
       (``STATUS_FOR_USER``) rather than be shoved out of the user by the contact pass.
    ``out_status[i]`` reports what happened as bit flags: ``STATUS_DENSE``
    (step 1 ran), ``STATUS_DROPPED_HEADING`` (step 2), ``STATUS_SOFT_OBSTACLES``
    (step 3), ``STATUS_DROPPED_MOTION`` (step 4), ``STATUS_FOR_USER`` (step 5's last resort).

Decoupled mode (``coupled=False``) is plain ORCA with no motion limits: the
baseline, and what the oracle test compares against RVO2.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from pedvr.crowd.coincident import COINCIDENT, apart
from pedvr.crowd.footprint import COVER_DISCS, cover_disc, support
from pedvr.crowd.headway import FOLLOW
from pedvr.crowd.neighbors import obstacle_neighbors_of
from pedvr.crowd.state import (
    LIMIT_ACCEL,
    LIMIT_BACKWARD,
    LIMIT_DECEL,
    LIMIT_SIDEWAYS,
    LIMIT_TURN_STANDING,
    LIMIT_TURN_WALKING,
)
from pedvr.kernels import parallel_kernel, row_njit

RVO_EPSILON = 1e-5  # RVO2's RVO_EPSILON
DEGENERATE_W = 1e-9  # m/s: in collision, a relative velocity this near the cut-off centre has no direction
STOPPED_SPEED = 0.05  # m/s: below this the motion direction is the heading
ACCEL_POLYGON_SIDES = 16
_POLYGON_STEP = 2.0 * math.pi / ACCEL_POLYGON_SIDES
# The acceleration polygon's vertex directions (cos, sin) at k 2π/16, k = 0..16, the last (1, 0)
# closing it: made once here, with the libm calls velocity_limit_lines made for every agent every
# step (17 sincos each; issue 27: 5 % of a 1000-agent step's CPU time). The same bytes.
ACCEL_POLYGON_DIRS = np.array([(math.cos(k * _POLYGON_STEP), math.sin(k * _POLYGON_STEP))
                               for k in range(ACCEL_POLYGON_SIDES)] + [(1.0, 0.0)])
SIDEWAYS_SLOPE = math.tan(math.radians(30.0))
# Lines one agent may add on top of its obstacle and agent lines in coupled mode.
MAX_MOTION_LINES = ACCEL_POLYGON_SIDES + 2 + 3

# Bit flags of ``out_status``.
STATUS_DENSE = 1  # linear_program3 ran: agent lines were softened
STATUS_DROPPED_HEADING = 2  # hard prefix infeasible: heading-relative limits (c) dropped
STATUS_DROPPED_MOTION = 4  # still infeasible: every motion limit dropped (plain ORCA)
STATUS_SOFT_OBSTACLES = 8  # obstacles and (a), (b) infeasible: obstacle lines softened, limits kept
STATUS_FOR_USER = 16  # the user's line held alone: a step aside beyond the body's limits (coupled)

_FM = {"nsz", "arcp", "contract", "afn"}  # no reassociation, no nnan/ninf (RVO2 uses inf)


# --------------------------------------------------------------------------- linear programs


@row_njit(fastmath=_FM, inline="always")
def _det(ax, ay, bx, by):
    return ax * by - ay * bx


@row_njit(fastmath=_FM)
def linear_program1(lines, line_no, radius, opt_x, opt_y, direction_opt):
    """Optimise on line ``line_no`` subject to lines ``[0, line_no)`` and the disc.

    Returns ``(ok, x, y)``; ``ok`` is false when the line's feasible interval
    is empty.
    """
    px = lines[line_no, 0]
    py = lines[line_no, 1]
    dx = lines[line_no, 2]
    dy = lines[line_no, 3]
    dot = px * dx + py * dy
    discriminant = dot * dot + radius * radius - (px * px + py * py)
    if discriminant < 0.0:
        # Max speed circle fully invalidates line line_no.
        return False, 0.0, 0.0
    sqrt_disc = math.sqrt(discriminant)
    t_left = -dot - sqrt_disc
    t_right = -dot + sqrt_disc
    for i in range(line_no):
        denominator = _det(dx, dy, lines[i, 2], lines[i, 3])
        numerator = _det(lines[i, 2], lines[i, 3], px - lines[i, 0], py - lines[i, 1])
        if abs(denominator) <= RVO_EPSILON:
            # Lines line_no and i are (almost) parallel.
            if numerator < 0.0:
                return False, 0.0, 0.0
            continue
        t = numerator / denominator
        if denominator >= 0.0:
            # Line i bounds line line_no on the right.
            t_right = min(t_right, t)
        else:
            # Line i bounds line line_no on the left.
            t_left = max(t_left, t)
        if t_left > t_right:
            return False, 0.0, 0.0
    if direction_opt:
        # Optimize direction.
        if opt_x * dx + opt_y * dy > 0.0:
            # Take right extreme.
            return True, px + t_right * dx, py + t_right * dy
        # Take left extreme.
        return True, px + t_left * dx, py + t_left * dy
    # Optimize closest point.
    t = dx * (opt_x - px) + dy * (opt_y - py)
    if t < t_left:
        return True, px + t_left * dx, py + t_left * dy
    if t > t_right:
        return True, px + t_right * dx, py + t_right * dy
    return True, px + t * dx, py + t * dy


@row_njit(fastmath=_FM)
def linear_program2(lines, n, radius, opt_x, opt_y, direction_opt):
    """Closest point to ``opt`` (or furthest along it) in lines ``[0, n)`` ∩ disc.

    Returns ``(fail, x, y)``: ``fail == n`` on success, else the index of the
    first line that made the program infeasible, with ``(x, y)`` the optimum of
    the lines before it (incremental algorithm, paper §5.2).
    """
    if direction_opt:
        # Optimize direction. The optimization velocity is of unit length here.
        rx = opt_x * radius
        ry = opt_y * radius
    elif opt_x * opt_x + opt_y * opt_y > radius * radius:
        # Optimize closest point and outside circle.
        norm = math.sqrt(opt_x * opt_x + opt_y * opt_y)
        rx = opt_x / norm * radius
        ry = opt_y / norm * radius
    else:
        # Optimize closest point and inside circle.
        rx = opt_x
        ry = opt_y
    for i in range(n):
        if _det(lines[i, 2], lines[i, 3], lines[i, 0] - rx, lines[i, 1] - ry) > 0.0:
            # Result does not satisfy constraint i. Compute new optimal result.
            ok, x, y = linear_program1(lines, i, radius, opt_x, opt_y, direction_opt)
            if not ok:
                return i, rx, ry
            rx = x
            ry = y
    return n, rx, ry


@row_njit(fastmath=_FM)
def linear_program3(lines, n, num_hard, begin, radius, rx, ry, proj):
    """Dense case (paper §5.3): minimise the largest violation of the soft lines.

    Lines ``[0, num_hard)`` (obstacles, motion limits) stay hard; ``proj`` is
    scratch with room for ``n`` lines. Returns the new ``(x, y)``.
    """
    distance = 0.0
    for i in range(begin, n):
        pix = lines[i, 0]
        piy = lines[i, 1]
        dix = lines[i, 2]
        diy = lines[i, 3]
        if _det(dix, diy, pix - rx, piy - ry) > distance:
            # Result does not satisfy constraint of line i.
            for k in range(num_hard):
                proj[k, 0] = lines[k, 0]
                proj[k, 1] = lines[k, 1]
                proj[k, 2] = lines[k, 2]
                proj[k, 3] = lines[k, 3]
            m = num_hard
            for j in range(num_hard, i):
                pjx = lines[j, 0]
                pjy = lines[j, 1]
                djx = lines[j, 2]
                djy = lines[j, 3]
                determinant = _det(dix, diy, djx, djy)
                if abs(determinant) <= RVO_EPSILON:
                    # Line i and line j are parallel.
                    if dix * djx + diy * djy > 0.0:
                        # Line i and line j point in the same direction.
                        continue
                    # Line i and line j point in opposite direction.
                    qx = 0.5 * (pix + pjx)
                    qy = 0.5 * (piy + pjy)
                else:
                    s = _det(djx, djy, pix - pjx, piy - pjy) / determinant
                    qx = pix + s * dix
                    qy = piy + s * diy
                ex = djx - dix
                ey = djy - diy
                norm = math.sqrt(ex * ex + ey * ey)
                proj[m, 0] = qx
                proj[m, 1] = qy
                proj[m, 2] = ex / norm
                proj[m, 3] = ey / norm
                m += 1
            fail, x, y = linear_program2(proj, m, radius, -diy, dix, True)
            if fail >= m:
                rx = x
                ry = y
            # else: in principle impossible (the result is already feasible);
            # floating point error, keep the current result.
            distance = _det(dix, diy, pix - rx, piy - ry)
    return rx, ry


# --------------------------------------------------------------------------- ORCA lines


@row_njit(fastmath=_FM)
def rigid_obstacle_lines(lines, px, py, vx, vy, a, b, fx, fy, inv_tho, obst_idx, n_obst, vertices, nxt, prv,
                         direction, convex, n_static):
    """Obstacle lines of a rigid footprint (a pushed pram's ellipse, ``a`` along its long axis,
    ``b`` across, the across direction ``(fx, fy)``; centre ``(px, py)``), as those of the
    discs that hold it (:func:`pedvr.crowd.footprint.cover_disc`, the door controller's), each
    disc's lines made as a disc's and judged covered only by its own. The ellipse does not turn
    as it moves in a step, so its velocity obstacle is the union of the discs'. One disc as
    wide as the ellipse's support toward each edge (:func:`obstacle_lines`) saw a doorway's jamb
    beside the pram's front as ahead of it, and let it on only at its clearance over the obstacle
    horizon: a pram 9 cm clear of both jambs crept through a double door's leaf until its
    passage timed out (issue 26, "no carrier left behind"; tests/crowd/test_pram_doorway.py:
    through a 1 m opening in 3.9 s, 1.7 s with the discs). Returns the line count."""
    n = 0
    ux = -fy  # the long axis (footprint.covering_discs)
    uy = fx
    for k in range(COVER_DISCS):
        x, rk = cover_disc(a, b, k)
        n = obstacle_lines(lines, n, px + x * ux, py + x * uy, vx, vy, rk, rk, fx, fy, False, inv_tho,
                           obst_idx, n_obst, vertices, nxt, prv, direction, convex, n_static, n)
    return n


@row_njit(fastmath=_FM)
def obstacle_lines(lines, n, px, py, vx, vy, disc_radius, depth, fx, fy, rigid, inv_tho, obst_idx, n_obst,
                   vertices, nxt, prv, direction, convex, n_static, covered_from=0):
    """Append obstacle ORCA lines (RVO2's first loop) and return the new count.

    ``obst_idx[:n_obst]`` are the edges (first-vertex indices) nearest first. The agent's
    radius toward each edge is its footprint's support from the edge's nearest point
    (``disc_radius`` unless it turned its shoulders: ``depth`` along the facing ``(fx,
    fy)``), so it changes continuously as the agent moves and turns. Edges from vertex
    ``n_static`` on (moving door leaves) see the disc, as the door controller does, unless the
    footprint is ``rigid`` (a pushed pram's, :mod:`pedvr.crowd.footprint`): that one they see as it is.
    Lines before ``covered_from`` are not taken to cover an edge (another body's, as in
    :func:`rigid_obstacle_lines`).
    """
    inf = np.inf
    for q in range(n_obst):
        o1 = obst_idx[q]
        o2 = nxt[o1]
        r1x = vertices[o1, 0] - px
        r1y = vertices[o1, 1] - py
        r2x = vertices[o2, 0] - px
        r2y = vertices[o2, 1] - py
        radius = disc_radius
        if depth < disc_radius and (o1 < n_static or rigid):
            ex = r2x - r1x
            ey = r2y - r1y
            ll = ex * ex + ey * ey
            tt = 0.0 if ll <= 0.0 else min(max(-(r1x * ex + r1y * ey) / ll, 0.0), 1.0)
            cx = -(r1x + tt * ex)
            cy = -(r1y + tt * ey)
            cl = math.sqrt(cx * cx + cy * cy)
            if cl > 1e-9:
                radius = support(disc_radius, depth, fx, fy, cx / cl, cy / cl)
        radius_sq = radius * radius

        # Check if velocity obstacle of obstacle is already taken care of by
        # previously constructed obstacle ORCA lines.
        already_covered = False
        for j in range(covered_from, n):
            ljx = lines[j, 0]
            ljy = lines[j, 1]
            djx = lines[j, 2]
            djy = lines[j, 3]
            if (_det(inv_tho * r1x - ljx, inv_tho * r1y - ljy, djx, djy) - inv_tho * radius
                    >= -RVO_EPSILON
                    and _det(inv_tho * r2x - ljx, inv_tho * r2y - ljy, djx, djy)
                    - inv_tho * radius >= -RVO_EPSILON):
                already_covered = True
                break
        if already_covered:
            continue

        # Not yet covered. Check for collisions.
        dist_sq1 = r1x * r1x + r1y * r1y
        dist_sq2 = r2x * r2x + r2y * r2y
        ovx = vertices[o2, 0] - vertices[o1, 0]
        ovy = vertices[o2, 1] - vertices[o1, 1]
        s = (-r1x * ovx - r1y * ovy) / (ovx * ovx + ovy * ovy)
        lx = -r1x - s * ovx
        ly = -r1y - s * ovy
        dist_sq_line = lx * lx + ly * ly

        if s < 0.0 and dist_sq1 <= radius_sq:
            # Collision with left vertex. Ignore if non-convex.
            if convex[o1]:
                norm = math.sqrt(dist_sq1)
                lines[n, 0] = 0.0
                lines[n, 1] = 0.0
                lines[n, 2] = -r1y / norm
                lines[n, 3] = r1x / norm
                n += 1
            continue
        if s > 1.0 and dist_sq2 <= radius_sq:
            # Collision with right vertex. Ignore if non-convex or if it will be
            # taken care of by the neighbouring obstacle.
            if convex[o2] and _det(r2x, r2y, direction[o2, 0], direction[o2, 1]) >= 0.0:
                norm = math.sqrt(dist_sq2)
                lines[n, 0] = 0.0
                lines[n, 1] = 0.0
                lines[n, 2] = -r2y / norm
                lines[n, 3] = r2x / norm
                n += 1
            continue
        if s >= 0.0 and s <= 1.0 and dist_sq_line <= radius_sq:
            # Collision with obstacle segment.
            lines[n, 0] = 0.0
            lines[n, 1] = 0.0
            lines[n, 2] = -direction[o1, 0]
            lines[n, 3] = -direction[o1, 1]
            n += 1
            continue

        # No collision. Compute legs. When obliquely viewed, both legs can come
        # from a single vertex. Legs extend cut-off line when nonconvex vertex.
        if s < 0.0 and dist_sq_line <= radius_sq:
            # Obstacle viewed obliquely so that left vertex defines velocity obstacle.
            if not convex[o1]:
                continue  # Ignore obstacle.
            o2 = o1
            leg1 = math.sqrt(dist_sq1 - radius_sq)
            llx = (r1x * leg1 - r1y * radius) / dist_sq1
            lly = (r1x * radius + r1y * leg1) / dist_sq1
            rlx = (r1x * leg1 + r1y * radius) / dist_sq1
            rly = (-r1x * radius + r1y * leg1) / dist_sq1
        elif s > 1.0 and dist_sq_line <= radius_sq:
            # Obstacle viewed obliquely so that right vertex defines velocity obstacle.
            if not convex[o2]:
                continue  # Ignore obstacle.
            o1 = o2
            leg2 = math.sqrt(dist_sq2 - radius_sq)
            llx = (r2x * leg2 - r2y * radius) / dist_sq2
            lly = (r2x * radius + r2y * leg2) / dist_sq2
            rlx = (r2x * leg2 + r2y * radius) / dist_sq2
            rly = (-r2x * radius + r2y * leg2) / dist_sq2
        else:
            # Usual situation.
            if convex[o1]:
                leg1 = math.sqrt(dist_sq1 - radius_sq)
                llx = (r1x * leg1 - r1y * radius) / dist_sq1
                lly = (r1x * radius + r1y * leg1) / dist_sq1
            else:
                # Left vertex non-convex; left leg extends cut-off line.
                llx = -direction[o1, 0]
                lly = -direction[o1, 1]
            if convex[o2]:
                leg2 = math.sqrt(dist_sq2 - radius_sq)
                rlx = (r2x * leg2 + r2y * radius) / dist_sq2
                rly = (-r2x * radius + r2y * leg2) / dist_sq2
            else:
                # Right vertex non-convex; right leg extends cut-off line.
                rlx = direction[o1, 0]
                rly = direction[o1, 1]

        # Legs can never point into neighbouring edge when convex vertex, take
        # cut-off line of neighbouring edge instead. If velocity projected on
        # "foreign" leg, no constraint is added.
        left_neighbor = prv[o1]
        left_foreign = False
        right_foreign = False
        if convex[o1] and _det(llx, lly, -direction[left_neighbor, 0],
                               -direction[left_neighbor, 1]) >= 0.0:
            # Left leg points into obstacle.
            llx = -direction[left_neighbor, 0]
            lly = -direction[left_neighbor, 1]
            left_foreign = True
        if convex[o2] and _det(rlx, rly, direction[o2, 0], direction[o2, 1]) <= 0.0:
            # Right leg points into obstacle.
            rlx = direction[o2, 0]
            rly = direction[o2, 1]
            right_foreign = True

        # Compute cut-off centres.
        lcx = inv_tho * (vertices[o1, 0] - px)
        lcy = inv_tho * (vertices[o1, 1] - py)
        rcx = inv_tho * (vertices[o2, 0] - px)
        rcy = inv_tho * (vertices[o2, 1] - py)
        cvx = rcx - lcx
        cvy = rcy - lcy

        # Project current velocity on velocity obstacle.
        # Check if current velocity is projected on cut-off circles.
        same = o1 == o2
        if same:
            t = 0.5
        else:
            t = ((vx - lcx) * cvx + (vy - lcy) * cvy) / (cvx * cvx + cvy * cvy)
        t_left = (vx - lcx) * llx + (vy - lcy) * lly
        t_right = (vx - rcx) * rlx + (vy - rcy) * rly

        if (t < 0.0 and t_left < 0.0) or (same and t_left < 0.0 and t_right < 0.0):
            # Project on left cut-off circle.
            wx = vx - lcx
            wy = vy - lcy
            norm = math.sqrt(wx * wx + wy * wy)
            uwx = wx / norm
            uwy = wy / norm
            lines[n, 2] = uwy
            lines[n, 3] = -uwx
            lines[n, 0] = lcx + radius * inv_tho * uwx
            lines[n, 1] = lcy + radius * inv_tho * uwy
            n += 1
            continue
        if t > 1.0 and t_right < 0.0:
            # Project on right cut-off circle.
            wx = vx - rcx
            wy = vy - rcy
            norm = math.sqrt(wx * wx + wy * wy)
            uwx = wx / norm
            uwy = wy / norm
            lines[n, 2] = uwy
            lines[n, 3] = -uwx
            lines[n, 0] = rcx + radius * inv_tho * uwx
            lines[n, 1] = rcy + radius * inv_tho * uwy
            n += 1
            continue

        # Project on left leg, right leg, or cut-off line, whichever is closest
        # to velocity.
        if t < 0.0 or t > 1.0 or same:
            dist_sq_cutoff = inf
        else:
            ex = vx - (lcx + t * cvx)
            ey = vy - (lcy + t * cvy)
            dist_sq_cutoff = ex * ex + ey * ey
        if t_left < 0.0:
            dist_sq_left = inf
        else:
            ex = vx - (lcx + t_left * llx)
            ey = vy - (lcy + t_left * lly)
            dist_sq_left = ex * ex + ey * ey
        if t_right < 0.0:
            dist_sq_right = inf
        else:
            ex = vx - (rcx + t_right * rlx)
            ey = vy - (rcy + t_right * rly)
            dist_sq_right = ex * ex + ey * ey

        if dist_sq_cutoff <= dist_sq_left and dist_sq_cutoff <= dist_sq_right:
            # Project on cut-off line.
            dlx = -direction[o1, 0]
            dly = -direction[o1, 1]
            lines[n, 2] = dlx
            lines[n, 3] = dly
            lines[n, 0] = lcx + radius * inv_tho * -dly
            lines[n, 1] = lcy + radius * inv_tho * dlx
            n += 1
            continue
        if dist_sq_left <= dist_sq_right:
            # Project on left leg.
            if left_foreign:
                continue
            lines[n, 2] = llx
            lines[n, 3] = lly
            lines[n, 0] = lcx + radius * inv_tho * -lly
            lines[n, 1] = lcy + radius * inv_tho * llx
            n += 1
            continue
        # Project on right leg.
        if right_foreign:
            continue
        lines[n, 2] = -rlx
        lines[n, 3] = -rly
        lines[n, 0] = rcx + radius * inv_tho * rly
        lines[n, 1] = rcy + radius * inv_tho * -rlx
        n += 1
    return n


@row_njit(fastmath=_FM)
def agent_line(lines, n, px, py, vx, vy, radius, qx, qy, wvx, wvy, other_radius, inv_th,
               inv_dt, share, i, j):
    """Append the ORCA line induced by neighbour row ``j`` on row ``i``; ``share`` is i's part of ``u``.

    In collision, ``u`` leaves the cut-off circle of time ``dt`` along ``w``, the relative
    velocity from that circle's centre; where ``w`` vanishes (the relative velocity is exactly
    the one that closes the gap in ``dt``, e.g. two bodies at one point standing still), RVO2
    divides by zero. Here ``u`` then points from ``j`` to ``i`` (each moves away from the other),
    and for coincident centres along :func:`pedvr.crowd.coincident.apart` (issue 24)."""
    rpx = qx - px
    rpy = qy - py
    rvx = vx - wvx
    rvy = vy - wvy
    dist_sq = rpx * rpx + rpy * rpy
    combined = radius + other_radius
    combined_sq = combined * combined
    if dist_sq > combined_sq:
        # No collision. Vector from cut-off centre to relative velocity.
        wx = rvx - inv_th * rpx
        wy = rvy - inv_th * rpy
        w_len_sq = wx * wx + wy * wy
        dot = wx * rpx + wy * rpy
        if dot < 0.0 and dot * dot > combined_sq * w_len_sq:
            # Project on cut-off circle.
            w_len = math.sqrt(w_len_sq)
            uwx = wx / w_len
            uwy = wy / w_len
            dx = uwy
            dy = -uwx
            ux = (combined * inv_th - w_len) * uwx
            uy = (combined * inv_th - w_len) * uwy
        else:
            # Project on legs.
            leg = math.sqrt(dist_sq - combined_sq)
            if _det(rpx, rpy, wx, wy) > 0.0:
                # Project on left leg.
                dx = (rpx * leg - rpy * combined) / dist_sq
                dy = (rpx * combined + rpy * leg) / dist_sq
            else:
                # Project on right leg.
                dx = -(rpx * leg + rpy * combined) / dist_sq
                dy = -(-rpx * combined + rpy * leg) / dist_sq
            dot2 = rvx * dx + rvy * dy
            ux = dot2 * dx - rvx
            uy = dot2 * dy - rvy
    else:
        # Collision. Project on cut-off circle of time timeStep.
        wx = rvx - inv_dt * rpx
        wy = rvy - inv_dt * rpy
        w_len_sq = wx * wx + wy * wy
        if w_len_sq > DEGENERATE_W * DEGENERATE_W:
            w_len = math.sqrt(w_len_sq)
            uwx = wx / w_len
            uwy = wy / w_len
        else:
            # At the cut-off centre: no direction out; away from the neighbour.
            w_len = 0.0
            if dist_sq > COINCIDENT * COINCIDENT:
                dist = math.sqrt(dist_sq)
                uwx = -rpx / dist
                uwy = -rpy / dist
            else:
                uwx, uwy = apart(i, j)
        dx = uwy
        dy = -uwx
        ux = (combined * inv_dt - w_len) * uwx
        uy = (combined * inv_dt - w_len) * uwy
    lines[n, 0] = vx + share * ux
    lines[n, 1] = vy + share * uy
    lines[n, 2] = dx
    lines[n, 3] = dy
    return n + 1


@row_njit(fastmath=_FM, inline="always")
def _pair_support(ai, bi, fxi, fyi, aj, bj, fxj, fyj, nx, ny):
    """Support of the pair's Minkowski sum (both footprints, :mod:`pedvr.crowd.footprint`) along
    the unit ``(nx, ny)``: how far from ``j``'s centre ``i``'s centre is when the two touch with
    ``(nx, ny)`` normal to the line that separates them."""
    return support(ai, bi, fxi, fyi, nx, ny) + support(aj, bj, fxj, fyj, nx, ny)


@row_njit(fastmath=_FM)
def shaped_agent_line(lines, n, px, py, vx, vy, qx, qy, wvx, wvy, ai, bi, fxi, fyi, aj, bj, fxj, fyj,
                      inv_th, inv_dt, share, i, j):
    """:func:`agent_line` for a pair of which one footprint is not a disc (a turned body, a pram;
    :func:`agent_lines` uses it for the line toward the user): the velocity obstacle of the two
    footprints' Minkowski sum ``M``, whose support ``h(n)`` is the sum of theirs, in place of a
    disc.

    A disc of one radius cannot stand for ``M``: as wide as ``M`` along the line of centres, it
    makes a person who turned sideways against a wall as wide as their shoulders to someone
    coming up from behind, and ORCA chases them ahead (issue 24, item 10). So each of ORCA's
    lines is the support line of ``M``'s (truncated) velocity obstacle that RVO2's case picks:

    * collision: ``h`` along the line of centres, as the contact pass measures overlaps;
    * the cut-off circle: the support line of ``(rp + M) / τ`` normal to ``w`` (``h(ŵ) / τ``
      from its centre);
    * a leg: the line through the origin tangent to ``rp + M``: at angle ``φ`` to ``rp`` with
      ``|rp| sin φ = h(m)``, ``m`` its normal, solved by a few fixed-point steps (it may reach
      90°: beside a long body the obstacle is nearly a half-plane).

    For discs every ``h`` is ``r_i + r_j`` and this is :func:`agent_line`; two rows of a pair
    would build mirrored lines (``h`` is symmetric)."""
    rpx = qx - px
    rpy = qy - py
    rvx = vx - wvx
    rvy = vy - wvy
    dist_sq = rpx * rpx + rpy * rpy
    dist = math.sqrt(dist_sq)
    if dist > COINCIDENT:
        cx = rpx / dist
        cy = rpy / dist
    else:
        cx, cy = apart(j, i)
    combined = _pair_support(ai, bi, fxi, fyi, aj, bj, fxj, fyj, cx, cy)
    if dist > combined:
        # No collision. Vector from cut-off centre to relative velocity.
        wx = rvx - inv_th * rpx
        wy = rvy - inv_th * rpy
        w_len_sq = wx * wx + wy * wy
        dot = wx * rpx + wy * rpy
        cut = combined
        if w_len_sq > 0.0:
            w_len = math.sqrt(w_len_sq)
            cut = _pair_support(ai, bi, fxi, fyi, aj, bj, fxj, fyj, wx / w_len, wy / w_len)
        if dot < 0.0 and dot * dot > cut * cut * w_len_sq:
            # Project on cut-off circle (the support line of the cut-off normal to w).
            w_len = math.sqrt(w_len_sq)
            uwx = wx / w_len
            uwy = wy / w_len
            dx = uwy
            dy = -uwx
            ux = (cut * inv_th - w_len) * uwx
            uy = (cut * inv_th - w_len) * uwy
        else:
            # Project on legs: the tangent from the origin to rp + M on w's side.
            side = 1.0 if _det(rpx, rpy, wx, wy) > 0.0 else -1.0
            sn = min(combined / dist, 1.0)
            for _ in range(4):
                cs = math.sqrt(max(1.0 - sn * sn, 0.0))
                # m: the leg's normal toward rp + M, rp turned by side * (phi - 90 deg).
                mx = cx * sn + side * cy * cs
                my = cy * sn - side * cx * cs
                sn = min(_pair_support(ai, bi, fxi, fyi, aj, bj, fxj, fyj, mx, my) / dist, 1.0)
            cs = math.sqrt(max(1.0 - sn * sn, 0.0))
            # The leg: rp turned by side * phi.
            dx = side * (cx * cs - side * cy * sn)
            dy = side * (cy * cs + side * cx * sn)
            dot2 = rvx * dx + rvy * dy
            ux = dot2 * dx - rvx
            uy = dot2 * dy - rvy
    else:
        # Collision. Project on cut-off circle of time timeStep.
        wx = rvx - inv_dt * rpx
        wy = rvy - inv_dt * rpy
        w_len_sq = wx * wx + wy * wy
        if w_len_sq > DEGENERATE_W * DEGENERATE_W:
            w_len = math.sqrt(w_len_sq)
            uwx = wx / w_len
            uwy = wy / w_len
        else:
            # At the cut-off centre: no direction out; away from the neighbour.
            w_len = 0.0
            uwx = -cx
            uwy = -cy
        dx = uwy
        dy = -uwx
        ux = (combined * inv_dt - w_len) * uwx
        uy = (combined * inv_dt - w_len) * uwy
    lines[n, 0] = vx + share * ux
    lines[n, 1] = vy + share * uy
    lines[n, 2] = dx
    lines[n, 3] = dy
    return n + 1


# --------------------------------------------------------------------------- motion limits


@row_njit(inline="always")
def _put_line(lines, n, px, py, dx, dy):
    lines[n, 0] = px
    lines[n, 1] = py
    lines[n, 2] = dx
    lines[n, 3] = dy
    return n + 1


@row_njit(fastmath=_FM)
def velocity_limit_lines(lines, n, vx, vy, heading, limits, pref_speed, dt):
    """Append (a) acceleration polygon and (b) turn-rate pair; return the new count.

    Both are centred on the current velocity ``v``, so ``v`` always satisfies
    them (see the module docstring for the geometry).
    """
    s = math.sqrt(vx * vx + vy * vy)
    if s >= STOPPED_SPEED:
        fx = vx / s
        fy = vy / s
    else:
        fx = math.cos(heading)
        fy = math.sin(heading)
    # Left normal of the motion direction.
    gx = -fy
    gy = fx
    r_fwd = limits[LIMIT_ACCEL] * dt
    r_back = limits[LIMIT_DECEL] * dt
    r_lat = min(r_fwd, r_back)
    # (a) 16-gon, counter-clockwise, vertices on two half-ellipses; edge k runs
    # from vertex k to k+1 and the inside is on its left.
    prev_x = 0.0
    prev_y = 0.0
    for k in range(ACCEL_POLYGON_SIDES + 1):
        c = ACCEL_POLYGON_DIRS[k, 0]
        sn = ACCEL_POLYGON_DIRS[k, 1]
        along = (r_fwd if c >= 0.0 else r_back) * c
        across = r_lat * sn
        x = vx + along * fx + across * gx
        y = vy + along * fy + across * gy
        if k > 0:
            ex = x - prev_x
            ey = y - prev_y
            norm = math.sqrt(ex * ex + ey * ey)
            if norm > 0.0:
                n = _put_line(lines, n, prev_x, prev_y, ex / norm, ey / norm)
        prev_x = x
        prev_y = y
    # (b) turn rate falling with speed: lateral change of velocity bounded.
    if s >= STOPPED_SPEED:
        frac = min(s / pref_speed, 1.0) if pref_speed > 0.0 else 1.0
        omega = limits[LIMIT_TURN_STANDING] + (
            limits[LIMIT_TURN_WALKING] - limits[LIMIT_TURN_STANDING]) * frac
        half = max(s * omega, limits[LIMIT_ACCEL]) * dt
        # (v' - v)·g <= half: point v + half g, direction -f (inside on the left).
        n = _put_line(lines, n, vx + half * gx, vy + half * gy, -fx, -fy)
        # (v' - v)·g >= -half: point v - half g, direction f.
        n = _put_line(lines, n, vx - half * gx, vy - half * gy, fx, fy)
    return n


@row_njit(fastmath=_FM)
def heading_limit_lines(lines, n, heading, limits):
    """Append (c): backward speed and speed-dependent sideways speed w.r.t. the heading."""
    hx = math.cos(heading)
    hy = math.sin(heading)
    back = limits[LIMIT_BACKWARD]
    side = limits[LIMIT_SIDEWAYS]
    k = SIDEWAYS_SLOPE
    if back > 0.0:
        k = min(k, side / back)
    # v·h >= -back: left normal of the direction must be h.
    n = _put_line(lines, n, -back * hx, -back * hy, hy, -hx)
    # v·h⊥ <= side + k v·h, with h⊥ = (-hy, hx): normal m = h⊥ - k h, m·v <= side.
    mx = -hy - k * hx
    my = hx - k * hy
    mm = math.sqrt(mx * mx + my * my)
    mx /= mm
    my /= mm
    off = side / mm
    # Inside is the side of -m: the direction whose left normal is -m is (-my, mx).
    n = _put_line(lines, n, off * mx, off * my, -my, mx)
    # -v·h⊥ <= side + k v·h: normal m2 = -h⊥ - k h.
    mx = hy - k * hx
    my = -hx - k * hy
    mm = math.sqrt(mx * mx + my * my)
    mx /= mm
    my /= mm
    off = side / mm
    n = _put_line(lines, n, off * mx, off * my, -my, mx)
    return n


# --------------------------------------------------------------------------- one agent


@row_njit(fastmath=_FM)
def _shift_lines(lines, src, dst, count):
    for k in range(count):
        lines[dst + k, 0] = lines[src + k, 0]
        lines[dst + k, 1] = lines[src + k, 1]
        lines[dst + k, 2] = lines[src + k, 2]
        lines[dst + k, 3] = lines[src + k, 3]


@row_njit(fastmath=_FM)
def _rotate_front(lines, first, second, scratch):
    """Swap the first two blocks of ``lines`` (``first`` rows, then ``second`` rows) in place,
    through ``scratch`` (room for ``first`` rows)."""
    _copy_lines(lines, 0, scratch, 0, first)
    _shift_lines(lines, first, 0, second)
    _copy_lines(scratch, 0, lines, second, first)


@row_njit(fastmath=_FM)
def user_line_at(i, is_user, nbr_idx, nbr_count, user_horizon, first):
    """Index in ``lines`` of agent ``i``'s line toward the user (its neighbours' lines start at
    ``first``, in :func:`agent_lines`' order), or -1 where it has none."""
    if user_horizon <= 0.0:
        return -1
    for q in range(nbr_count[i]):
        if is_user[nbr_idx[i, q]]:
            return first + q
    return -1


@row_njit(fastmath=_FM)
def _line_to(lines, src, dst, scratch):
    """Move line ``src`` to ``dst <= src``, the lines between one row on (order otherwise kept)."""
    _copy_lines(lines, src, scratch, 0, 1)
    for k in range(src, dst, -1):
        _copy_lines(lines, k - 1, lines, k, 1)
    _copy_lines(scratch, 0, lines, dst, 1)


@row_njit(fastmath=_FM)
def _copy_lines(src, at, dst, to, count):
    for k in range(count):
        dst[to + k, 0] = src[at + k, 0]
        dst[to + k, 1] = src[at + k, 1]
        dst[to + k, 2] = src[at + k, 2]
        dst[to + k, 3] = src[at + k, 3]


@row_njit(fastmath=_FM)
def _solve(lines, n, num_hard, max_speed, prx, pry, proj):
    fail, rx, ry = linear_program2(lines, n, max_speed, prx, pry, False)
    if fail < n:
        rx, ry = linear_program3(lines, n, num_hard, fail, max_speed, rx, ry, proj)
    return rx, ry


@row_njit(fastmath=_FM)
def agent_lines(i, pos, vel, radius, depth, facing, rigid, is_user, heading, pref_speed, limits,
                nbr_idx, nbr_count, obst_idx, n_obst, vertices, nxt, prv, direction, convex,
                n_static, time_horizon, time_horizon_obst, user_horizon, dt, coupled, lines):
    """Write agent ``i``'s ORCA lines into ``lines``: obstacle lines, then (coupled) the
    velocity-limit lines (a, b) and the heading lines (c), then one line per neighbour.

    Footprints: each pair's combined radius is the sum of the two bodies' support
    radii along the line of centres, and each obstacle edge sees the agent's support
    toward it (equal to the disc radii unless someone turned their shoulders).

    The user: its line is the late safety step of the encounter model
    (:mod:`pedvr.crowd.encounter`): share 1 (the user does not reciprocate) with the
    short horizon ``user_horizon`` and the contact radii (no personal-space margin); the
    agent's share ρ of the avoidance is taken earlier, in its preferred velocity.
    ``user_horizon <= 0`` switches the safety step off (no line toward the user).

    Returns ``(n, num_obst, num_vel_lim, num_hard)``: the line count, the number of
    obstacle lines, of velocity-limit lines, and of hard lines (everything before the
    neighbours' lines).
    """
    px = pos[i, 0]
    py = pos[i, 1]
    vx = vel[i, 0]
    vy = vel[i, 1]
    r = radius[i]
    b = depth[i]
    fx = facing[i, 0]
    fy = facing[i, 1]
    if rigid[i] and b < r:
        n = rigid_obstacle_lines(lines, px, py, vx, vy, r, b, fx, fy, 1.0 / time_horizon_obst, obst_idx,
                                 n_obst, vertices, nxt, prv, direction, convex, n_static)
    else:
        n = obstacle_lines(lines, 0, px, py, vx, vy, r, b, fx, fy, rigid[i], 1.0 / time_horizon_obst,
                           obst_idx, n_obst, vertices, nxt, prv, direction, convex, n_static)
    num_obst = n
    num_vel_lim = 0
    if coupled:
        n = velocity_limit_lines(lines, n, vx, vy, heading[i], limits[i], pref_speed[i], dt)
        num_vel_lim = n - num_obst
        n = heading_limit_lines(lines, n, heading[i], limits[i])
    num_hard = n
    inv_th = 1.0 / time_horizon
    inv_dt = 1.0 / dt
    for q in range(nbr_count[i]):
        j = nbr_idx[i, q]
        if is_user[j]:
            if user_horizon <= 0.0:
                continue
            share = 1.0
            inv = 1.0 / user_horizon
        else:
            share = 0.5
            inv = inv_th
        qx = pos[j, 0]
        qy = pos[j, 1]
        if is_user[j] and (b < r or depth[j] < radius[j]):
            # The safety step toward the user, with a footprint that is not a disc: the obstacle of
            # the two footprints themselves (a disc as wide as the pair along the line of centres
            # makes an agent turned against a wall as wide as its shoulders to a user coming up
            # behind it, and a line of share 1 then chases it ahead, into a dead end: issue 24).
            n = shaped_agent_line(lines, n, px, py, vx, vy, qx, qy, vel[j, 0], vel[j, 1], r, b, fx, fy,
                                  radius[j], depth[j], facing[j, 0], facing[j, 1], inv, inv_dt, share, i, j)
            continue
        ri = r
        rj = radius[j]
        dx = qx - px
        dy = qy - py
        d = math.sqrt(dx * dx + dy * dy)
        if d > 1e-9 and (b < r or depth[j] < rj):
            # Between agents: a disc of the two supports along the line of centres. Wider than the
            # pair where they pass side by side, but both yield and the contact pass holds the
            # rest; the exact obstacle here would change how crowds squeeze past each other.
            ri = support(r, b, fx, fy, dx / d, dy / d)
            rj = support(rj, depth[j], facing[j, 0], facing[j, 1], -dx / d, -dy / d)
        n = agent_line(lines, n, px, py, vx, vy, ri, qx, qy, vel[j, 0], vel[j, 1], rj, inv,
                       inv_dt, share, i, j)
    return n, num_obst, num_vel_lim, num_hard


@row_njit(fastmath=_FM)
def agent_new_velocity(i, pos, vel, pref_vel, radius, depth, facing, rigid, max_speed, is_user,
                       heading, pref_speed, limits, nbr_idx, nbr_count, obst_idx, n_obst,
                       vertices, nxt, prv, direction, convex, n_static, time_horizon,
                       time_horizon_obst, user_horizon, dt, coupled, lines, proj, intent, slack=0.0):
    """New velocity of agent ``i`` (RVO2's ``computeNewVelocity`` plus limits).

    ``lines``/``proj`` are scratch of at least ``COVER_DISCS n_obst + K + MAX_MOTION_LINES``
    rows. Returns ``(vx, vy, status)`` with ``STATUS_*`` bit flags. ``slack``: the dense
    case's slack toward the preferred velocity (:func:`toward_preferred`; 0: the paper's least
    violation, which the caller gives near the user or a door leaf: :func:`near_user_or_leaf`),
    only against neighbours going the agent's way (``intent``: the velocities the agents mean to
    walk, before the time gap and the encounters).
    """
    n, num_obst, num_vel_lim, num_hard = agent_lines(
        i, pos, vel, radius, depth, facing, rigid, is_user, heading, pref_speed, limits, nbr_idx,
        nbr_count, obst_idx, n_obst, vertices, nxt, prv, direction, convex, n_static, time_horizon,
        time_horizon_obst, user_horizon, dt, coupled, lines)
    num_agent = n - num_hard
    ms = max_speed[i]
    prx = pref_vel[i, 0]
    pry = pref_vel[i, 1]
    fail, rx, ry = linear_program2(lines, n, ms, prx, pry, False)
    status = 0
    if coupled and fail < num_hard and num_hard > num_obst:
        # Hard prefix infeasible: drop the heading lines (c) first ...
        status = STATUS_DROPPED_HEADING
        _shift_lines(lines, num_hard, num_obst + num_vel_lim, num_agent)
        num_hard = num_obst + num_vel_lim
        n = num_hard + num_agent
        fail, rx, ry = linear_program2(lines, n, ms, prx, pry, False)
        if fail < num_hard:
            # ... then the obstacle lines go soft behind the velocity limits (a), (b) ...
            _rotate_front(lines, num_obst, num_vel_lim, proj)
            fail, rx, ry = linear_program2(lines, n, ms, prx, pry, False)
            if fail >= num_vel_lim:
                status = STATUS_DROPPED_HEADING | STATUS_SOFT_OBSTACLES
                num_hard = num_vel_lim
            else:
                # ... and only if (a), (b) alone are infeasible, every motion limit: plain ORCA.
                _rotate_front(lines, num_vel_lim, num_obst, proj)
                status = STATUS_DROPPED_MOTION
                _shift_lines(lines, num_hard, num_obst, num_agent)
                num_hard = num_obst
                n = num_hard + num_agent
                fail, rx, ry = linear_program2(lines, n, ms, prx, pry, False)
    if coupled and fail < n:
        at = user_line_at(i, is_user, nbr_idx, nbr_count, user_horizon, n - num_agent)
        if at >= 0:
            # No velocity keeps every line: the user's line joins the hard ones where it can, so
            # the least violation falls on the agents' and the softened walls' lines, never on the
            # person's body (the contact pass pushes bodies apart and out of walls, never into the
            # user; with the user's line among the soft ones a squeezed agent was steered 1-2 cm
            # into the user in corridor_passing)
            _line_to(lines, at, num_hard, proj)
            fail2, rx2, ry2 = linear_program2(lines, n, ms, prx, pry, False)
            if fail2 > num_hard:
                num_hard += 1
            else:
                # not even within the body's limits (the user walks into it faster than it can
                # step away): the user's line alone stays hard, the limits and walls give for this
                # step, rather than the contact pass shoving the body out of the user afterwards
                _line_to(lines, num_hard, 0, proj)
                num_hard = 1
                status |= STATUS_FOR_USER
                fail2, rx2, ry2 = linear_program2(lines, n, ms, prx, pry, False)
            fail, rx, ry = fail2, rx2, ry2
    if fail < n:
        status |= STATUS_DENSE
        rx, ry = linear_program3(lines, n, num_hard, fail, ms, rx, ry, proj)
        hard_ok = status == STATUS_DENSE  # every motion limit and obstacle line held as it was
        if slack > 0.0 and hard_ok:
            rx, ry = toward_preferred(lines, n, num_hard, ms, prx, pry, rx, ry, slack,
                                      nbr_idx[i], intent, pos, pos[i, 0], pos[i, 1])
    return rx, ry, status


@row_njit(fastmath=_FM, inline="always")
def obstacle_horizon(near, time_horizon_obst, short):
    """The obstacle horizon (s) an agent steers with: ``short`` (coupled, outside a door's
    etiquette: ``[steering] time_horizon_obst_coupled``), but ``time_horizon_obst`` where it is
    ``near`` the user or a door leaf (:func:`near_user_or_leaf`), as the dense slack
    (:func:`toward_preferred`) keeps away from them; never longer than ``time_horizon_obst``.

    Issue 26: with walls seen 1 s ahead people slow at the edges of an opening a second before
    they reach them (bottleneck_050 0.80 /s against the real 1.16). Seen 0.5 s ahead everywhere,
    a boxed-in agent in ``shibuya_crossing`` came 1-2 cm into the user's disc once in 60 s (the
    user does not steer; with 1 s it had kept further from the kerb and the user), and a pram at
    ``door_assist`` was left waiting alone at the door until it reached for the handle itself.
    The obstacle neighbours are found with ``time_horizon_obst``'s range in either case, so the
    choice is the same whatever the horizon."""
    if near or short >= time_horizon_obst:
        return time_horizon_obst
    return short


@row_njit(fastmath=_FM)
def near_user_or_leaf(i, is_user, nbr_idx, nbr_count, obst_idx, n_obst, n_static):
    """Whether agent ``i`` has the user among its neighbours or a door leaf (a moving segment,
    vertex ``>= n_static``) among its obstacle edges: there coupled ORCA keeps the paper's
    least violation and obstacle horizon (:func:`toward_preferred`, :func:`obstacle_horizon`)."""
    for q in range(nbr_count[i]):
        if is_user[nbr_idx[i, q]]:
            return True
    for q in range(n_obst):
        if obst_idx[q] >= n_static:
            return True
    return False


@row_njit(fastmath=_FM)
def toward_preferred(lines, n, num_hard, max_speed, prx, pry, rx, ry, slack, nbrs, intent, pos, px, py):
    """Dense case (coupled, ``[steering] dense_slack``): among the velocities inside the hard lines
    that violate no agent line by more than ``slack`` m/s beyond ``linear_program3``'s least
    largest violation at ``(rx, ry)``, the one nearest the preferred velocity ``(prx, pry)``.

    The paper's §5.3 picks the least-violating velocity whatever the agent's goal; in a crowd
    pressing on an opening (issue 26) that was 60-70 % of the steps of the people in front of it,
    and they drifted sideways at 0.3-0.4 m/s while making 0.02 m/s toward the opening. Here the
    agent lines are moved back by that violation plus ``slack`` and the ordinary program is solved
    toward the preferred velocity; the hard lines stay as they are. Returns ``(rx, ry)`` unchanged
    if that fails (floating point). The agent lines in ``lines`` are left moved.

    Only the lines of neighbours the agent would push the way they go get the slack: ``j =
    nbrs[k - num_hard]`` whose ``intent[j]`` (what it means to walk, before the time gap) has at
    least :data:`pedvr.crowd.headway.FOLLOW` m/s along the line from the agent at ``(px, py)`` to
    it (``pos[j]``). The line of one standing, coming toward the agent or going across its push
    is moved back by the least violation only: the agent presses no harder on it than the
    paper's velocity would. (With the slack on every line, people pressing on in
    ``shibuya_crossing`` shoved a waiting agent backwards at 0.69 m/s and, with standing ones
    spared, an oncoming walker at 0.80 m/s, past the 0.5 m/s a body steps backwards. Before an
    opening the one pressed on is nearer the opening and going there. Sparing instead every
    neighbour not going the agent's own way, ``intent[j]`` along ``intent[i]``, was as safe
    there, and one seed did not tell the two apart at the openings (uo_070 1.10 against
    1.17 /s, bottleneck_050 0.85 against 0.74); this rule names the hazard itself, a push
    against where someone goes.)

    :func:`agent_new_velocity` calls it only where the whole hard prefix (obstacles, motion
    limits, heading limits) was feasible, so every limit holds and no obstacle line is moved;
    never for an agent with the user among its neighbours (the user's line, share 1 and its own
    horizon, is not loosened: near the user the encounter model and ``user_responsibility``
    decide); and never near a door leaf, where the door etiquette orders who goes (with the
    slack an early group's member was left behind at ``door_late_group``, seed 2)."""
    worst = 0.0
    for k in range(num_hard, n):
        worst = max(worst, _det(lines[k, 2], lines[k, 3], lines[k, 0] - rx, lines[k, 1] - ry))
    for k in range(num_hard, n):
        j = nbrs[k - num_hard]
        dx = pos[j, 0] - px
        dy = pos[j, 1] - py
        d = math.sqrt(dx * dx + dy * dy)
        shift = worst
        if d > 1e-9 and intent[j, 0] * dx + intent[j, 1] * dy >= FOLLOW * d:
            shift += slack
        lines[k, 0] += shift * lines[k, 3]
        lines[k, 1] -= shift * lines[k, 2]
    fail, x, y = linear_program2(lines, n, max_speed, prx, pry, False)
    if fail < n:
        return rx, ry
    return x, y


# --------------------------------------------------------------------------- batch


@parallel_kernel(fastmath=_FM, allocates=False)
def orca_kernel(pos, vel, pref_vel, radius, depth, facing, rigid, max_speed, is_user, heading,
                pref_speed, limits, nbr_idx, nbr_count, vertices, nxt, prv, direction, convex,
                n_static, og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges,
                og_edge_cells, time_horizon, time_horizon_obst, short_obst, user_horizon, dt, coupled,
                chunk_bounds,
                scratch_lines, scratch_proj, scratch_oidx, scratch_odsq,
                out_vel, out_status, out_obst_count, intent, slack):
    """New velocities of every row, parallel over chunks of agents.

    Chunk ``c`` handles rows ``chunk_bounds[c]:chunk_bounds[c+1]`` with its
    own scratch ``scratch_*[c]`` (preallocated by the caller, reused for every
    agent of the chunk). ``out_obst_count[i]`` is the true number of obstacle
    neighbours; where it exceeds ``scratch_oidx.shape[1]`` the agent's result
    is invalid and the caller must retry with more room. User rows copy their
    input velocity. ``short_obst`` ``(N,)``: each agent's obstacle horizon (s) away from the user
    and door leaves (:func:`obstacle_horizon`; ``time_horizon_obst`` near them). ``intent``
    ``(N,2)`` and ``slack`` ``(N,)``: what each agent means to walk and its dense slack
    (:func:`toward_preferred`; 0: the paper's least violation).
    """
    nchunks = chunk_bounds.shape[0] - 1
    for c in prange(nchunks):
        lines = scratch_lines[c]
        proj = scratch_proj[c]
        oidx = scratch_oidx[c]
        odsq = scratch_odsq[c]
        cap = oidx.shape[0]
        for i in range(chunk_bounds[c], chunk_bounds[c + 1]):
            if is_user[i]:
                out_vel[i, 0] = vel[i, 0]
                out_vel[i, 1] = vel[i, 1]
                out_status[i] = 0
                out_obst_count[i] = 0
                continue
            rng = time_horizon_obst * max_speed[i] + radius[i]
            n_obst = obstacle_neighbors_of(pos[i, 0], pos[i, 1], rng * rng, vertices, nxt,
                                           og_origin, og_cell, og_nx, og_ny, og_cell_start,
                                           og_cell_edges, og_edge_cells, oidx, odsq)
            out_obst_count[i] = n_obst
            if n_obst > cap:
                out_vel[i, 0] = vel[i, 0]
                out_vel[i, 1] = vel[i, 1]
                out_status[i] = 0
                continue
            # near the user or a door leaf: the paper's obstacle horizon and least violation
            near = near_user_or_leaf(i, is_user, nbr_idx, nbr_count, oidx, n_obst, n_static)
            tho = obstacle_horizon(near, time_horizon_obst, short_obst[i])
            sl = 0.0 if near else slack[i]
            rx, ry, status = agent_new_velocity(
                i, pos, vel, pref_vel, radius, depth, facing, rigid, max_speed, is_user, heading,
                pref_speed, limits, nbr_idx, nbr_count, oidx, n_obst, vertices, nxt, prv,
                direction, convex, n_static, time_horizon, tho, user_horizon, dt,
                coupled, lines, proj, intent, sl)
            out_vel[i, 0] = rx
            out_vel[i, 1] = ry
            out_status[i] = status
