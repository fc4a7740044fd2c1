"""The coordinator's pose dataflow graph, run for one body at a time (ADAPT §4.3–4.5).

:func:`pose_graph_kernel` executes, for each body in turn, the whole pipeline that
:class:`~pedvr.body.coordinator.Coordinator` describes: the pose starts at rest, and each
choreographer in the coordinator's order poses its shadow (generators from nothing, transformers
from the pose flowing through the graph) and is blended in on its joints with the body's weight;
then the final leg-IK node and forward kinematics. The order, the weights, the masks and which
nodes move the pelvis are data (the coordinator's), not code: the kernel dispatches on node ids.

Running the graph per body instead of per node keeps a body's pose and shadow in a few hundred
bytes of scratch instead of six ``(N, 26, 4)`` buffers, and lets a node with weight 0 cost nothing:
a zero-weight blend leaves the pose as it is, so the shadow is not made (most bodies are not
sitting, gesturing or reaching). Bodies are independent, so the result does not depend on the
order they are run in.

The same per-body functions serve the batch kernels in :mod:`pedvr.body.pose` (one node for the
whole crowd, as the tests drive them) and :func:`gaze_targets_kernel` (what each body attends to,
for the overhead view).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from pedvr.body import actions as act
from pedvr.body import pose as ps
from pedvr.body import skeleton as sk
from pedvr.body.quat import FASTMATH, fk_row, qmul4, qrot3
from pedvr.kernels import row_njit, sincos

NODE_NAMES = ("locomotion", "sitting", "gesture", "idle", "gaze", "reach")
LOCOMOTION, SITTING, GESTURE, IDLE, GAZE, REACH = range(6)
GAZE_NONE, GAZE_POINT, GAZE_AGENT, GAZE_USER = 0, 1, 2, 3

# Subconscious arm actions' hand goals, relative to a body segment (Ashida §4.2: "goal positions
# relative to the coordinate frame of the relevant body segment", so the hand follows a moving
# head): segment node, local x (left arm; mirrored for the right), y, z in metres for the 1.75 m
# reference adult (scaled per body), and a scratching oscillation amplitude (m, at 4 Hz).
ARM_GOALS = np.full((act.N_ACTIONS, 5), -1.0)
ARM_GOALS[act.A_HEAD_TOUCH] = (sk.HEAD, 0.09, 0.03, 0.05, 0.0)
ARM_GOALS[act.A_HEAD_SCRATCH] = (sk.HEAD, 0.07, 0.11, -0.02, 0.02)
ARM_GOALS[act.A_YAWN] = (sk.HEAD, 0.0, -0.02, 0.13, 0.0)
ARM_GOALS[act.A_BODY_TOUCH] = (sk.SPINE3, 0.06, -0.02, 0.13, 0.0)
ARM_GOALS[act.A_BODY_SCRATCH] = (sk.SPINE1, 0.12, -0.05, 0.10, 0.02)
ARM_ACTIONS = np.flatnonzero(ARM_GOALS[:, 0] >= 0)

LOOK_AROUND_REACH = 3.0  # m: a look around aims this far out, sweeping ±1 rad about the facing
LOOK_DOWN_REACH = 1.2  # m: a look down aims at the floor this far ahead


@njit(cache=True, fastmath=FASTMATH, inline="always")
def gaze_target_row(i, t, gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user, heads, run_kind,
                    run_start, heading, root, out):  # type: ignore[no-untyped-def]
    """What body ``i`` attends to: returns ``(has, deliberate)`` and writes the point to ``out (3,)``.

    Deliberate: ``gaze_at`` a point, an agent (``gaze_row`` its row, -1 if gone) or the user, or
    the PedVR gaze rule (toward the user's head). Otherwise a subconscious look around or look down
    running on the head (Ashida §3.1). Nothing: the controller returns to neutral.
    """
    k = gaze_kind[i]
    if k == GAZE_POINT:
        for c in range(3):
            out[c] = gaze_point[i, c]
        return True, True
    if k == GAZE_AGENT:
        r = gaze_row[i]
        if r >= 0:
            for c in range(3):
                out[c] = heads[r, c]
            return True, True
    elif (k == GAZE_USER or (k == GAZE_NONE and gaze_rule[i])) and has_user:
        for c in range(3):
            out[c] = user_head[c]
        return True, True
    for slot in range(run_kind.shape[1]):
        a = run_kind[i, slot]
        if a == act.A_LOOK_AROUND:
            since = t - run_start[i, slot]
            ang = heading[i] + math.sin(1.3 * since + 0.5)
            out[0] = heads[i, 0] + LOOK_AROUND_REACH * math.cos(ang)
            out[1] = heads[i, 1] + 0.1 * math.sin(since)
            out[2] = heads[i, 2] + LOOK_AROUND_REACH * math.sin(ang)
            return True, False
        if a == act.A_LOOK_DOWN:
            out[0] = root[i, 0] + LOOK_DOWN_REACH * math.cos(heading[i])
            out[1] = 0.0
            out[2] = root[i, 1] + LOOK_DOWN_REACH * math.sin(heading[i])
            return True, False
    return False, False


@njit(cache=True, fastmath=FASTMATH)
def gaze_targets_kernel(t, gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user, heads, run_kind,
                        run_start, heading, root, out, deliberate):  # type: ignore[no-untyped-def]
    """:func:`gaze_target_row` for every body: ``out (N,3)`` NaN where none; ``deliberate (N,)``."""
    for i in range(out.shape[0]):
        has, why = gaze_target_row(i, t, gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user,
                                   heads, run_kind, run_start, heading, root, out[i])
        deliberate[i] = has and why
        if not has:
            out[i, 0] = np.nan
            out[i, 1] = np.nan
            out[i, 2] = np.nan


@njit(cache=True)
def heads_kernel(world_pos, root, offsets, dims, out, fresh):  # type: ignore[no-untyped-def]
    """Head positions after the last frame, ``out (N, 3)``; ``fresh (N,)`` where no forward kinematics
    has run yet (the head at the origin), whose heads stand at the standing head height above the root."""
    for i in range(out.shape[0]):
        x, y, z = world_pos[i, sk.HEAD, 0], world_pos[i, sk.HEAD, 1], world_pos[i, sk.HEAD, 2]
        new = x == 0.0 and y == 0.0 and z == 0.0
        fresh[i] = new
        if new:
            out[i, 0] = root[i, 0]
            out[i, 1] = offsets[i, sk.PELVIS, 1] + 0.62 * dims[i, 3]
            out[i, 2] = root[i, 1]
        else:
            out[i, 0] = x
            out[i, 1] = y
            out[i, 2] = z


@njit(cache=True, fastmath=FASTMATH, inline="always")
def turn_shoulders(pose_q, turn):  # type: ignore[no-untyped-def]
    """Turn the upper torso by ``turn`` rad about the vertical relative to the pelvis (a body squeezing
    past someone shoulder first): half at Spine2, half at Spine3, so the chest and both shoulders
    follow; the neck turns back by as much, so the head keeps facing where it did (the walker still
    looks where it goes, and the gaze controller's work is kept). Pre-multiplied, as the gaze's
    rotations are: a turn about the parent's vertical."""
    half = sincos(0.25 * turn)
    back = sincos(-0.5 * turn)
    for j, (sy, cy) in ((sk.SPINE2, half), (sk.SPINE3, half), (sk.NECK, back)):
        x, y, z, w = qmul4(0.0, sy, 0.0, cy, pose_q[j, 0], pose_q[j, 1], pose_q[j, 2], pose_q[j, 3])
        pose_q[j, 0] = x
        pose_q[j, 1] = y
        pose_q[j, 2] = z
        pose_q[j, 3] = w


@njit(cache=True, fastmath=FASTMATH)
def gaze_rule_kernel(pos, vel, heading, is_user, u, d1, d2, cos_fov, out):  # type: ignore[no-untyped-def]
    """PedVR §4.2 eqs. 1–3 but visibility: ``out (N,)`` True where agent i is within ``d1`` of the
    user (row ``u``), closing on it at ``0 < w < d2`` with ``w = (v_i − v_u)·(p_u − p_i)/|p_u − p_i|``,
    and has the user inside its field of view (``cos_fov``: the cosine of half of it)."""
    for i in range(pos.shape[0]):
        out[i] = False
        if is_user[i]:
            continue
        dx = pos[u, 0] - pos[i, 0]
        dy = pos[u, 1] - pos[i, 1]
        dist = math.sqrt(dx * dx + dy * dy)
        if dist >= d1 or dist <= 1e-9:
            continue
        dx /= dist
        dy /= dist
        w = (vel[i, 0] - vel[u, 0]) * dx + (vel[i, 1] - vel[u, 1]) * dy
        if w > 0.0 and w < d2 and math.cos(heading[i]) * dx + math.sin(heading[i]) * dy >= cos_fov:
            out[i] = True


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _arm_goal(i, a, side, t, scale, seed, arm_goals, wp, wq, out):  # type: ignore[no-untyped-def]
    seg = int(arm_goals[a, 0])
    sc = scale[i]
    sgn = 1.0 if side == 0 else -1.0
    lx = sgn * arm_goals[a, 1] * sc
    ly = arm_goals[a, 2] * sc + arm_goals[a, 4] * math.sin(2.0 * math.pi * 4.0 * t + seed[i])
    lz = arm_goals[a, 3] * sc
    x, y, z = qrot3(wq[seg, 0], wq[seg, 1], wq[seg, 2], wq[seg, 3], lx, ly, lz)
    out[0] = wp[seg, 0] + x
    out[1] = wp[seg, 1] + y
    out[2] = wp[seg, 2] + z


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _arm_busy(i, side, run_kind, run_mask, arm_goals):  # type: ignore[no-untyped-def]
    """The running subconscious arm action on this arm, or -1."""
    bit = act.LEFT_ARM if side == 0 else act.RIGHT_ARM
    for slot in range(run_kind.shape[1]):
        a = run_kind[i, slot]
        if a >= 0 and arm_goals[a, 0] >= 0.0 and (run_mask[i, slot] & bit) != 0:
            return a
    return -1


@row_njit(fastmath=FASTMATH)
def _sit_node(sc, pelvis_rest, w, mask, moves_pelvis, pq, pp, sq, sp):  # type: ignore[no-untyped-def]
    ps.sit_row(sc, pelvis_rest, sq, sp)
    ps.blend_row(pq, pp, sq, sp, w, mask, moves_pelvis)


@row_njit(fastmath=FASTMATH)
def _gesture_node(t, g, start, duration, off, w, clip_masks, mask, pq, sq, sp, q1, q2, tq, tp):  # type: ignore[no-untyped-def]
    """The clip's shadow, blended only on the joints the clip drives (and the node's mask)."""
    ps.gesture_row(t, g, start, duration, off, sq, sp, q1, q2, tq, tp)
    for j in range(pq.shape[0]):
        if clip_masks[g, j] and mask[j]:
            ps.blend_joint(pq, sq, j, w)


@row_njit(fastmath=FASTMATH)
def _idle_node(t, seed, strength, sc, perm, w, mask, moves_pelvis, pq, pp, sq, sp):  # type: ignore[no-untyped-def]
    ps.idle_row(t, seed, strength, sc, perm, pq, pp, sq, sp)
    ps.blend_row(pq, pp, sq, sp, w, mask, moves_pelvis)


@row_njit(fastmath=FASTMATH)
def _gaze_node(dt, w, mask, has, goal, head, yaw, running, share, yaw_lim, pitch_lim, speed, alpha, ang,
               eye_l, eye_r, head_q, closed, pq, pp, sq, sp):  # type: ignore[no-untyped-def]
    ps.gaze_row(dt, has, goal, head, yaw, running, share, yaw_lim, pitch_lim, speed, alpha, ang, pq, sq,
                eye_l, eye_r, head_q, closed)
    ps.blend_row(pq, pp, sq, sp, w, mask, False)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _reach_needed(i, run_kind, run_mask, reach_on, arm_goals):  # type: ignore[no-untyped-def]
    for side in range(2):
        if reach_on[i, side] or _arm_busy(i, side, run_kind, run_mask, arm_goals) >= 0:
            return True
    return False


@row_njit(fastmath=FASTMATH)
def _reach_node(i, t, w, mask, run_kind, run_mask, reach_on, reach_pt, arm_goals, scale, seed, parents,
                off, root, yaw, pq, pp, sq, sp, wp, wq, active, target, q1, q2):  # type: ignore[no-untyped-def]
    # the thorax and the head where the blend has put them so far
    fk_row(parents, off, pq, root[i, 0], 0.0, root[i, 1], yaw, pp, wp, wq, sk.HEAD + 1)
    for side in range(2):
        active[side] = reach_on[i, side]
        for k in range(3):
            target[side, k] = reach_pt[i, side, k]
        if not reach_on[i, side]:
            a = _arm_busy(i, side, run_kind, run_mask, arm_goals)
            if a >= 0:
                _arm_goal(i, a, side, t, scale, seed, arm_goals, wp, wq, target[side])
                active[side] = True
    ps.reach_row(active, target, wq[sk.SPINE3], wp[sk.SPINE3], off, pq, sq, q1, q2)
    ps.blend_row(pq, pp, sq, sp, w, mask, False)


@row_njit(fastmath=FASTMATH)
def _arms_again(i, yaw, parents, off, root, pq, pp, wp, wq, active, target, q1, q2):  # type: ignore[no-untyped-def]
    """Solve the reaching arms again on the thorax where the legs' IK has just put it.

    The reach node solves the arms before the legs' IK sets the pelvis height, so where the knees
    bend (a walk starting or slowing) the hands would ride below what they hold by the height the
    pelvis dropped (up to 6 cm, a pram pusher in ``door_assist``). Solved again here, in the
    untwisted frame (the shoulders turn after this, taking the arms with the chest), the hands
    stay on their targets. Only a full-weight reach is solved again: a fading one blends."""
    fk_row(parents, off, pq, root[i, 0], 0.0, root[i, 1], yaw, pp, wp, wq, sk.HEAD + 1)
    for side in range(2):
        if active[side]:
            ps.arm_to(side, wq[sk.SPINE3], wp[sk.SPINE3], target[side, 0], target[side, 1], target[side, 2],
                      off, pq, q1, q2)


@njit(cache=True, fastmath=FASTMATH)
def _pose_rows(lo, hi, dt, t, order, weights, masks, moves_pelvis, clip_masks, phase, amp, style, scale,
               pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm, gaze_kind, gaze_point,
               gaze_row, gaze_rule, user_head, has_user, running, heading, ang, share, yaw_lim, pitch_lim,
               speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt, arm_goals, root, foot_ref,
               foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing, h_prev, ik_miss, heads, fresh,
               shoulder_turn, parents, local_q, pelvis, world_pos, world_q):  # type: ignore[no-untyped-def]
    """Bodies ``lo`` to ``hi - 1`` of :func:`pose_graph_kernel`, with their own scratch."""
    nk = parents.shape[0]
    sq = np.empty((local_q.shape[1], 4))
    sp = np.empty(3)
    q1 = np.empty(4)
    q2 = np.empty(4)
    tq = np.empty(4)
    tp = np.empty(3)
    anks = np.empty((2, 3))
    hips = np.empty((2, 3))
    trig = np.empty((2, 6))
    reach = np.empty(2)
    goal = np.empty(3)
    reach_active = np.zeros(2, np.bool_)
    reach_target = np.empty((2, 3))
    wp = np.empty((nk, 3))
    wq = np.empty((nk, 4))
    off = np.empty((nk, 3))
    alpha = np.empty(tau.shape[0])
    whole = np.empty(order.shape[0], np.bool_)
    _pose_span(lo, hi, dt, t, order, weights, masks, moves_pelvis, clip_masks, phase, amp, style, scale,
               pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm, gaze_kind, gaze_point,
               gaze_row, gaze_rule, user_head, has_user, running, heading, ang, share, yaw_lim, pitch_lim,
               speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt, arm_goals, root, foot_ref,
               foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing, h_prev, ik_miss, heads, fresh,
               shoulder_turn, parents, local_q, pelvis, world_pos, world_q,
               sq, sp, q1, q2, tq, tp, anks, hips, trig, reach, goal, reach_active, reach_target, wp, wq,
               off, alpha, whole)


@row_njit(fastmath=FASTMATH)
def _pose_span(lo, hi, dt, t, order, weights, masks, moves_pelvis, clip_masks, phase, amp, style, scale,
               pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm, gaze_kind, gaze_point,
               gaze_row, gaze_rule, user_head, has_user, running, heading, ang, share, yaw_lim, pitch_lim,
               speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt, arm_goals, root, foot_ref,
               foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing, h_prev, ik_miss, heads, fresh,
               shoulder_turn, parents, local_q, pelvis, world_pos, world_q,
               sq, sp, q1, q2, tq, tp, anks, hips, trig, reach, goal, reach_active, reach_target, wp, wq,
               off, alpha, whole):  # type: ignore[no-untyped-def]
    """:func:`_pose_rows`' work, in the scratch it allocated: no array is allocated or
    reference-counted here (:func:`pedvr.kernels.row_njit`)."""
    nk = parents.shape[0]
    ps.gaze_alpha(dt, tau, alpha)
    for c in range(order.shape[0]):  # whole[c]: the node at position c drives every joint and the pelvis
        whole[c] = moves_pelvis[c]
        for j in range(masks.shape[1]):
            whole[c] = whole[c] and masks[c, j]
    for i in range(lo, hi):
        pq = local_q[i]
        pp = pelvis[i]
        # the body's rest offsets from its four dims, in scratch: the same bytes as state.offsets
        # (skeleton.dims_offsets) without reading 0.8 kB a body from memory
        sk.offsets_row(dims[i, sk.DIM_SCALE], dims[i, sk.DIM_SEX], dims[i, sk.DIM_BUILD], off)
        ps.rest_pose(pq)
        pp[0] = 0.0
        pp[1] = 0.0
        pp[2] = 0.0
        yaw = 0.5 * math.pi - heading[i]
        reached = False  # a full-weight reach moved the arms (they are solved again after the legs' IK)
        for c in range(order.shape[0]):
            node = order[c, 0]
            w = weights[i, order[c, 1]]
            if w <= 0.0:
                continue  # a zero-weight blend leaves the pose as it is
            if node == LOCOMOTION:
                if w >= 1.0 and whole[c]:
                    # a full-weight blend of a shadow over every joint and the pelvis is the shadow:
                    # posed straight into the pose (also measurably faster than through the scratch)
                    ps.loco_row(phase[i], amp[i], style[i], scale[i], pelvis_rest[i], pq, pp)
                else:
                    ps.loco_row(phase[i], amp[i], style[i], scale[i], pelvis_rest[i], sq, sp)
                    ps.blend_row(pq, pp, sq, sp, w, masks[c], moves_pelvis[c])
            # The other nodes are separate functions, called: most bodies skip them, and keeping
            # their code out of this loop keeps the per-body path small (inlined, it ran 50 % slower).
            elif node == SITTING:
                _sit_node(scale[i], pelvis_rest[i], w, masks[c], moves_pelvis[c], pq, pp, sq, sp)
            elif node == GESTURE:
                if g_kind[i] != 0:
                    _gesture_node(t, g_kind[i], g_start[i], g_dur[i], off, w, clip_masks, masks[c], pq,
                                  sq, sp, q1, q2, tq, tp)
            elif node == IDLE:
                if idle_w[i] > 0.0:
                    _idle_node(t, noise_seed[i], idle_w[i], scale[i], perm, w, masks[c], moves_pelvis[c], pq,
                               pp, sq, sp)
            elif node == GAZE:
                has, _ = gaze_target_row(i, t, gaze_kind, gaze_point, gaze_row, gaze_rule, user_head,
                                         has_user, heads, run_kind, run_start, heading, root, goal)
                # at rest, with nothing to look at, the gaze's shadow is the pose itself
                if not ps.gaze_at_rest(has, ang[i]):
                    _gaze_node(dt, w, masks[c], has, goal, heads[i], yaw, running[i], share, yaw_lim[i],
                               pitch_lim, speed, alpha, ang[i], world_pos[i, sk.L_EYE],
                               world_pos[i, sk.R_EYE], world_q[i, sk.HEAD], not fresh[i], pq, pp, sq, sp)
            elif node == REACH:
                if _reach_needed(i, run_kind, run_mask, reach_on, arm_goals):  # else no arm to move
                    _reach_node(i, t, w, masks[c], run_kind, run_mask, reach_on, reach_pt, arm_goals, scale,
                                noise_seed, parents, off, root, yaw, pq, pp, sq, sp, wp, wq, reach_active,
                                reach_target, q1, q2)
                    reached = w >= 1.0
        h_prev[i] = ps.leg_ik_row(dt, root[i, 0], root[i, 1], yaw, off, foot_ref[i], foot_yaw[i],
                                  foot_pitch[i], foot_lift[i], planted[i], stepping[i], s[i], swing[i],
                                  h_prev[i], pq, pp, ik_miss[i], q1, q2, anks, hips, trig, reach)
        if reached:
            _arms_again(i, yaw, parents, off, root, pq, pp, wp, wq, reach_active, reach_target, q1, q2)
        if shoulder_turn[i] != 0.0:  # after the legs' IK, which does not read the spine
            turn_shoulders(pq, shoulder_turn[i])
        fk_row(parents, off, pq, root[i, 0], 0.0, root[i, 1], yaw, pp, world_pos[i], world_q[i], nk)


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def _pose_chunks(chunks, dt, t, order, weights, masks, moves_pelvis, clip_masks, phase, amp, style, scale,
                  pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm, gaze_kind,
                  gaze_point, gaze_row, gaze_rule, user_head, has_user, running, heading, ang, share,
                  yaw_lim, pitch_lim, speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt,
                  arm_goals, root, foot_ref, foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing,
                  h_prev, ik_miss, heads, fresh, shoulder_turn, parents, local_q, pelvis, world_pos, world_q):  # type: ignore[no-untyped-def]
    """:func:`_pose_rows` over chunks of bodies in parallel (a few chunks per thread)."""
    n = local_q.shape[0]
    for c in prange(chunks):
        _pose_rows(c * n // chunks, (c + 1) * n // chunks, dt, t, order, weights, masks, moves_pelvis,
                   clip_masks, phase, amp, style, scale, pelvis_rest, dims, g_kind, g_start, g_dur,
                   noise_seed, idle_w, perm, gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user,
                   running, heading, ang, share, yaw_lim, pitch_lim, speed, tau, run_kind, run_mask,
                   run_start, reach_on, reach_pt, arm_goals, root, foot_ref, foot_yaw, foot_pitch, foot_lift,
                   planted, stepping, s, swing, h_prev, ik_miss, heads, fresh, shoulder_turn, parents,
                   local_q, pelvis, world_pos, world_q)


def pose_graph_kernel(dt, t, order, weights, masks, moves_pelvis, clip_masks,
                      phase, amp, style, scale, pelvis_rest, dims,
                      g_kind, g_start, g_dur, noise_seed, idle_w, perm,
                      gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user, running, heading, ang,
                      share, yaw_lim, pitch_lim, speed, tau,
                      run_kind, run_mask, run_start, reach_on, reach_pt, arm_goals,
                      root, foot_ref, foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing, h_prev,
                      ik_miss, heads, fresh, shoulder_turn, parents, local_q, pelvis, world_pos,
                      world_q, chunks=0):  # type: ignore[no-untyped-def]
    """Pose every body: the coordinator's graph, the leg-IK node and forward kinematics.

    A Python function choosing the compiled loop: the serial one, or the parallel chunks, which
    numba compiles only when a run first asks for them (a parallel kernel is among the slowest
    to compile; issue 27: the default scene never runs it).

    Graph: ``order (C, 2) int64`` rows of (node id, weight column) in blending order, ``weights (N,
    W)``, ``masks (C, J)`` and ``moves_pelvis (C,)`` per position in ``order``; ``clip_masks (G,
    J)`` the joints each gesture clip drives (a gesture node blends only those). Node inputs are the
    body state's arrays (:class:`pedvr.body.model.BodyState`); ``dims (N, 4)`` stand for the rest
    offsets (:func:`pedvr.body.skeleton.offsets_row`, the bytes of ``state.offsets``); ``g_kind`` is
    the clip playing or fading (0 none), ``idle_w`` the idle noise's strength, ``gaze_row`` the row
    of a gazed-at agent, ``running`` the locomotion's message. ``heads (N,3)`` are the head
    positions after the last frame (``fresh`` where no forward kinematics has run yet: the eyes
    cannot close the loop there). ``shoulder_turn (N,)`` rad turns the upper torso about the
    vertical relative to the pelvis (:func:`turn_shoulders`). Outputs: ``local_q (N,J,4)``, ``pelvis
    (N,3)`` the final pose, ``world_pos (N,K,3)``, ``world_q (N,K,4)`` its forward kinematics; the
    gaze state ``ang``, the pelvis height ``h_prev``, ``foot_pitch`` (heel rise) and ``ik_miss`` are
    updated. ``yaw_lim (N, 5)`` is per body (a gaze capped by ``FullBody.gaze_limit``), the other
    gaze parameters are shared. ``chunks > 0`` runs the bodies in that many chunks in parallel, 0 in
    one serial loop (the same bytes either way: bodies are independent).
    """
    if chunks > 0:
        _pose_chunks(min(chunks, local_q.shape[0]), dt, t, order, weights, masks, moves_pelvis, clip_masks,
                     phase, amp, style, scale,
                     pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm, gaze_kind,
                     gaze_point, gaze_row, gaze_rule, user_head, has_user, running, heading, ang, share,
                     yaw_lim, pitch_lim, speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt,
                     arm_goals, root, foot_ref, foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing,
                     h_prev, ik_miss, heads, fresh, shoulder_turn, parents, local_q, pelvis, world_pos,
                     world_q)
    else:
        _pose_rows(0, local_q.shape[0], dt, t, order, weights, masks, moves_pelvis, clip_masks, phase, amp,
                   style, scale, pelvis_rest, dims, g_kind, g_start, g_dur, noise_seed, idle_w, perm,
                   gaze_kind, gaze_point, gaze_row, gaze_rule, user_head, has_user, running, heading, ang,
                   share, yaw_lim, pitch_lim, speed, tau, run_kind, run_mask, run_start, reach_on, reach_pt,
                   arm_goals, root, foot_ref, foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing,
                   h_prev, ik_miss, heads, fresh, shoulder_turn, parents, local_q, pelvis, world_pos, world_q)
