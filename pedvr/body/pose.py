"""Choreographer kernels: each poses a shadow ``(N, J, 4)`` local rotations + ``(N, 3)`` pelvis.

Each node is written once, for one body (``*_row``: a pose ``(J, 4)`` and a pelvis ``(3,)``), and
run either by its batch kernel (a loop over the crowd, for the tests and for single nodes) or inside
:func:`pedvr.body.graph.pose_graph_kernel`, which runs the whole graph for one body at a time.

Generators write a whole shadow (locomotion, sitting, gestures); transformers
take the pose flowing through the coordinator's graph and write their shadow
from it (idle noise, gaze, reach). The final leg-IK node
(:func:`leg_ik_kernel`) is ADAPT's shadow post-processing filter: it lowers
the pelvis as far as the planted feet require and solves the legs so the
feet sit exactly where the footstep planner put them, whatever the blend
did to the pelvis.

Angles are radians. Local rotation conventions follow
:mod:`pedvr.body.skeleton` (+Y up, +Z forward, +X left): flexion of the
spine and pitch-down of the head are +X rotations, arm and elbow flexion
(forward) are −X, yaw toward the left is +Y.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pedvr.body import skeleton as sk
from pedvr.body.locomotion import DS, foot_pose_cs
from pedvr.body.quat import FASTMATH, euler_yxz4, frame_quat, qmul4, qrot3
from pedvr.body.style import PA, PB, Pa, Pb, Pp
from pedvr.kernels import cosine, row_njit, sincos, sine, wrap_pi

PELVIS_YAW = 0.07  # rad: transverse pelvic rotation at a walk (±4°)
PELVIS_LIST = 0.05  # rad: pelvic obliquity (±3°)
PELVIS_TILT = 0.03  # rad: forward tilt at a walk
SWAY = 0.02  # m (reference adult): lateral pelvis sway toward the stance foot
BOB = 0.045  # m (reference adult): pelvis bob, peak to peak, at 1.35 m/s (people: 4-5 cm)
BOB_EXP = 0.7  # bob ∝ speed^0.7: about 2 cm at 0.5 m/s, 5.5 cm at 1.8 m/s (people: 5-6 cm)
KNEE_STAND = math.radians(5.0)  # knee flexion of a person standing at ease (and at mid-stance)
KNEE_MIN = math.radians(2.0)  # the straightest a planted leg gets (heel strike, toe-off)
LEG_REACH = 0.99999  # fraction of thigh + shin the IK may use (the KNEE_MIN reach binds first)
RISE_RATE = 0.6  # m/s: fastest the pelvis rises (it falls as fast as the feet need)
PELVIS_FLOOR = 0.8  # fraction of the standing pelvis height the reach limit may not go below
PITCH_MAX = math.radians(60.0)  # the most a heel-up foot rises onto its toes to keep the leg reaching
PITCH_MAX_COS, PITCH_MAX_SIN = math.cos(PITCH_MAX), math.sin(PITCH_MAX)
_SQRT_HALF = math.sqrt(0.5)

# Gaze controller (SmartBody-like). Order: lumbar, thorax, neck, head, eyes.
GAZE_LUMBAR, GAZE_THORAX, GAZE_NECK, GAZE_HEAD, GAZE_EYES = 0, 1, 2, 3, 4
GAZE_SHARE = np.array([0.1, 0.15, 0.3, 0.45])  # share of the remaining rotation, body joints
GAZE_YAW_LIMIT = np.radians([10.0, 15.0, 35.0, 45.0, 35.0])  # neck + head = 80° on the trunk
GAZE_PITCH_LIMIT = np.radians([5.0, 8.0, 20.0, 25.0, 25.0])
GAZE_SPEED = np.radians([30.0, 45.0, 100.0, 200.0, 600.0])  # °/s caps; head-on-trunk ≤ 300 °/s
GAZE_TAU = np.array([0.45, 0.35, 0.22, 0.15, 0.03])  # s: smoothing time constants (eyes lead)
RUNNING_TORSO = 0.3  # while "running", lumbar and thorax keep this fraction of their limits



def knee_reach(l1: float, l2: float, flexion: float) -> float:
    """Hip-to-ankle distance of a leg (thigh ``l1``, shin ``l2``) with the knee flexed ``flexion`` rad."""
    return math.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * math.cos(flexion))


_THIGH, _SHIN = -sk.REST_OFFSETS[sk.L_KNEE, 1], -sk.REST_OFFSETS[sk.L_ANKLE, 1]
KNEE_BEND = _THIGH + _SHIN - knee_reach(_THIGH, _SHIN, KNEE_STAND)
"""m (reference adult): the standing pelvis below a straight-leg height (KNEE_STAND; 0.8 mm)."""
KNEE_MIN_COS = math.cos(KNEE_MIN)

UPPER_MASK = np.zeros(sk.J, np.bool_)
UPPER_MASK[sk.SPINE1:sk.J] = True

# Gesture clips (PedVR §4.3).
GESTURES = ("none", "wave", "point", "shrug", "check_phone", "hands_in_pockets", "talk")
G_NONE, G_WAVE, G_POINT, G_SHRUG, G_PHONE, G_POCKETS, G_TALK = range(7)


def _clip_mask(*groups: tuple[int, ...]) -> np.ndarray:
    m = np.zeros(sk.J, np.bool_)
    for g in groups:
        m[list(g)] = True
    return m


_R_ARM = (sk.R_COLLAR, sk.R_COLLAR + 1, sk.R_COLLAR + 2, sk.R_COLLAR + 3, sk.R_COLLAR + 4)
_L_ARM = (sk.L_COLLAR, sk.L_COLLAR + 1, sk.L_COLLAR + 2, sk.L_COLLAR + 3, sk.L_COLLAR + 4)
# The joints each clip drives: only these leave the walk (a wave keeps the other arm swinging and
# the torso's style); the rest of the upper body goes on with what the blend below gives it.
GESTURE_MASKS = np.stack([
    _clip_mask(),
    _clip_mask(_R_ARM, (sk.HEAD,)),
    _clip_mask(_R_ARM),
    _clip_mask(_R_ARM, _L_ARM, (sk.HEAD,)),
    _clip_mask(_R_ARM, _L_ARM, (sk.NECK, sk.HEAD)),
    _clip_mask(_R_ARM, _L_ARM),
    _clip_mask(_R_ARM, _L_ARM),
])

_PERM = np.random.default_rng(0x9E11).permutation(256)
PERM = np.concatenate([_PERM, _PERM]).astype(np.int64)
"""Fixed permutation of the 1D improved-Perlin kernel (a constant, not state)."""


@njit(cache=True, fastmath=FASTMATH)
def spow(x, p):  # type: ignore[no-untyped-def]
    return math.copysign(abs(x) ** p, x) if p != 1.0 else x


@njit(cache=True, fastmath=FASTMATH)
def _put(q, j, t):  # type: ignore[no-untyped-def]
    q[j, 0] = t[0]
    q[j, 1] = t[1]
    q[j, 2] = t[2]
    q[j, 3] = t[3]


@njit(cache=True, fastmath=FASTMATH)
def rest_pose(q):  # type: ignore[no-untyped-def]
    """Every joint of one pose ``(J, 4)`` back to the identity rotation (a generator's blank shadow)."""
    for j in range(q.shape[0]):
        q[j, 0] = 0.0
        q[j, 1] = 0.0
        q[j, 2] = 0.0
        q[j, 3] = 1.0


@njit(cache=True, fastmath=FASTMATH)
def copy_pose(src_q, src_p, dst_q, dst_p):  # type: ignore[no-untyped-def]
    """A transformer's shadow starts as the pose flowing through the graph."""
    for j in range(src_q.shape[0]):
        for k in range(4):
            dst_q[j, k] = src_q[j, k]
    for k in range(3):
        dst_p[k] = src_p[k]


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _phase_sin(dof, t):  # type: ignore[no-untyped-def]
    """A DOF's phase argument ``a t + b`` and its sine (for :func:`_dof_shared`); ``dof`` its style row."""
    x = dof[Pa] * t + dof[Pb]
    return x, sine(x)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _dof_shared(dof, t, amp, xa, sa, xb, sb, xc, sc):  # type: ignore[no-untyped-def]
    """Ashida's DOF whose style row is ``dof``, ``A amp sin(a t + b)^p + B``
    (:mod:`pedvr.body.style`), for less than a sine each: a DOF whose phase argument equals one already taken
    (``xa``, ``xb``, ``xc`` with sines ``sa``, ``sb``, ``sc``) reuses that sine (Ashida's arm DOFs
    share the arm swing's phase, the spine's the gait's), and a still DOF (``A = 0``) with a
    non-zero posture ``B`` is ``B`` (``±0 + B``) without a sine (issue 27: 16 sines a body were
    a tenth of the pose graph)."""
    if dof[PA] == 0.0 and dof[PB] != 0.0:
        return dof[PB]
    x = dof[Pa] * t + dof[Pb]
    if x == xa:
        s = sa
    elif x == xb:
        s = sb
    elif x == xc:
        s = sc
    else:
        s = sine(x)
    return dof[PA] * amp * spow(s, dof[Pp]) + dof[PB]


@njit(cache=True, fastmath=FASTMATH)
def _rot_x(a):  # type: ignore[no-untyped-def]
    """``euler_yxz4(0, a, 0)``."""
    s, c = sincos(0.5 * a)
    return s, 0.0, 0.0, c


@njit(cache=True, fastmath=FASTMATH)
def _rot_yz(yaw, roll):  # type: ignore[no-untyped-def]
    """``euler_yxz4(yaw, 0, roll)``."""
    sy, cy = sincos(0.5 * yaw)
    sr, cr = sincos(0.5 * roll)
    return sy * sr, sy * cr, cy * sr, cy * cr


@njit(cache=True, fastmath=FASTMATH)
def _rot_xz(pitch, roll):  # type: ignore[no-untyped-def]
    """``euler_yxz4(0, pitch, roll)``."""
    sp, cp = sincos(0.5 * pitch)
    sr, cr = sincos(0.5 * roll)
    return sp * cr, -sp * sr, cp * sr, cp * cr


# -- generators -----------------------------------------------------------------------------------

@row_njit(fastmath=FASTMATH)
def loco_row(t, a, style, sc, pelvis_rest, out_q, out_p):  # type: ignore[no-untyped-def]
    """One body's locomotion shadow (see :func:`loco_shadow_kernel`); ``style (11, 5)``.

    A function of its own, called, not inlined into numba's IR (nor is :func:`leg_ik_row`, nor
    :func:`pedvr.body.quat.fk_row`; issue 27 goal 2): inlined twice into
    :func:`pedvr.body.graph._pose_span` (it poses straight into the pose or into scratch), with the
    sixteen DOF helpers inlined into it, the pose graph's one kernel took 216 s of a 313 s cold
    compile on this 2-core VM, most of it numba's SSA pass over that one function; now 81 s of 183 s,
    with the same bytes. Called costs about 4 % of the pose graph's time (about 0.06 ms a step at
    1000 bodies, seven pairs of runs). The DOF helpers stay inlined here: called as well, the kernel
    compiled in 55 s but ran about 13 % slower (three pairs; and with ``style`` and an index for
    arguments numba compiled them once per index, typed as a literal: they take the DOF's row)."""
    rest_pose(out_q)
    st, ct = sincos(t)
    py = -PELVIS_YAW * ct * a
    pl = PELVIS_LIST * st * a
    pt = PELVIS_TILT * min(a, 1.0)
    _put(out_q, sk.PELVIS, euler_yxz4(py, pt, pl))
    out_p[0] = SWAY * sc * st * a
    # lowest at each heel strike (double support), highest at mid-stance; amp = speed / 1.3
    bob = BOB * sc * (a * (1.3 / 1.35)) ** BOB_EXP * 0.5 * (1.0 + cosine(2.0 * t))
    out_p[1] = pelvis_rest - KNEE_BEND * sc - bob
    out_p[2] = 0.0
    # lower spine: counter-rotate the pelvis (spread over Spine1, Spine2) + style
    x8, s8 = _phase_sin(style[8], t)
    x9, s9 = _phase_sin(style[9], t)
    x10, s10 = _phase_sin(style[10], t)
    lf = _dof_shared(style[8], t, a, x8, s8, x8, s8, x8, s8)
    lb = _dof_shared(style[9], t, a, x9, s9, x9, s9, x9, s9)
    lt = _dof_shared(style[10], t, a, x10, s10, x10, s10, x10, s10)
    q = euler_yxz4(0.5 * (lt - py), 0.5 * (lf - pt), 0.5 * (lb - pl))
    _put(out_q, sk.SPINE1, q)
    _put(out_q, sk.SPINE2, q)
    uf = _dof_shared(style[5], t, a, x8, s8, x9, s9, x10, s10)
    ub = _dof_shared(style[6], t, a, x8, s8, x9, s9, x10, s10)
    ut = _dof_shared(style[7], t, a, x8, s8, x9, s9, x10, s10)
    q = euler_yxz4(0.5 * ut, 0.5 * uf, 0.5 * ub)
    _put(out_q, sk.SPINE3, q)
    _put(out_q, sk.NECK, q)
    for side in range(2):
        ts = t + math.pi * side  # right side: same curve shifted by π
        sgn = 1.0 if side == 0 else -1.0
        x0, s0 = _phase_sin(style[0], ts)  # DOFs 0..MIRRORED-1 are the mirrored arm DOFs
        x3, s3 = _phase_sin(style[3], ts)
        elbow = _dof_shared(style[0], ts, a, x0, s0, x0, s0, x0, s0)
        sflex = _dof_shared(style[1], ts, a, x0, s0, x3, s3, x3, s3)
        sabd = _dof_shared(style[2], ts, a, x0, s0, x3, s3, x3, s3)
        celev = _dof_shared(style[3], ts, a, x3, s3, x3, s3, x3, s3)
        cprot = _dof_shared(style[4], ts, a, x0, s0, x3, s3, x3, s3)
        c = sk.L_COLLAR if side == 0 else sk.R_COLLAR
        _put(out_q, c, _rot_yz(-sgn * cprot, sgn * celev))
        _put(out_q, c + 1, _rot_xz(-sflex, sgn * sabd))
        _put(out_q, c + 2, _rot_x(-elbow))


@njit(cache=True, fastmath=FASTMATH)
def loco_shadow_kernel(phase, amp, style, scale, pelvis_rest, out_q, out_p):  # type: ignore[no-untyped-def]
    """Locomotion's shadow: pelvis gait rotation, sway and bob; Ashida's upper body.

    ``phase (N,)`` gait phase (0 at left heel strike), ``amp (N,)`` gait
    amplitude (speed / 1.3, smoothed), ``style (N,11,5)``, ``pelvis_rest
    (N,)`` standing pelvis height. Legs are left at identity (the IK node
    solves them).
    """
    for i in range(phase.shape[0]):
        loco_row(phase[i], amp[i], style[i], scale[i], pelvis_rest[i], out_q[i], out_p[i])


@row_njit(fastmath=FASTMATH)
def sit_row(sc, pelvis_rest, out_q, out_p):  # type: ignore[no-untyped-def]
    rest_pose(out_q)
    out_p[0] = 0.0
    out_p[1] = 0.50 * sc
    out_p[2] = -0.30 * sc
    _put(out_q, sk.PELVIS, euler_yxz4(0.0, -0.08, 0.0))
    _put(out_q, sk.SPINE1, euler_yxz4(0.0, 0.06, 0.0))
    for c in (sk.L_COLLAR, sk.R_COLLAR):
        _put(out_q, c + 1, euler_yxz4(0.0, -0.35, 0.0))
        _put(out_q, c + 2, euler_yxz4(0.0, -1.0, 0.0))


@njit(cache=True, fastmath=FASTMATH)
def sit_shadow_kernel(scale, pelvis_rest, out_q, out_p):  # type: ignore[no-untyped-def]
    """Sitting: pelvis down and back, trunk upright, forearms on the thighs."""
    for i in range(scale.shape[0]):
        sit_row(scale[i], pelvis_rest[i], out_q[i], out_p[i])


@njit(cache=True, fastmath=FASTMATH)
def _fade(t):  # type: ignore[no-untyped-def]
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(cache=True, fastmath=FASTMATH)
def perlin1d(x, perm):  # type: ignore[no-untyped-def]
    """Improved Perlin noise in 1D (Perlin 2002): fade 6t⁵−15t⁴+10t³, gradients ±1; in [-1, 1]."""
    xf = math.floor(x)
    i0 = int(xf) & 255
    f = x - xf
    g0 = f if (perm[i0] & 1) == 0 else -f
    g1 = (f - 1.0) if (perm[i0 + 1] & 1) == 0 else (1.0 - f)
    return 2.0 * (g0 + _fade(f) * (g1 - g0))


# -- transformers ---------------------------------------------------------------------------------

@row_njit(fastmath=FASTMATH)
def idle_row(t, s, w, sc, perm, in_q, in_p, out_q, out_p):  # type: ignore[no-untyped-def]
    """One body's idle noise over ``in`` (see :func:`idle_kernel`)."""
    copy_pose(in_q, in_p, out_q, out_p)
    if w <= 0.0:
        return
    out_p[0] += w * 0.012 * sc * perlin1d(0.25 * t + s, perm)
    out_p[2] += w * 0.006 * sc * perlin1d(0.21 * t + s + 17.3, perm)
    # a slight, slow knee bend (≤ 1.4 mm of pelvis: near-straight knees flex fast with depth)
    out_p[1] -= w * 0.0007 * sc * (1.0 + perlin1d(0.3 * t + s + 5.1, perm))
    for j, f, ay, ap, ar, off in ((sk.SPINE2, 0.3, 0.015, 0.012, 0.01, 31.7),
                                  (sk.NECK, 0.35, 0.06, 0.03, 0.01, 47.9),
                                  (sk.HEAD, 0.45, 0.05, 0.04, 0.02, 63.1),
                                  (sk.L_SHOULDER, 0.4, 0.0, 0.03, 0.01, 80.3),
                                  (sk.R_SHOULDER, 0.4, 0.0, 0.03, 0.01, 96.7)):
        dy = w * ay * perlin1d(f * t + s + off, perm)
        dp = w * ap * perlin1d(f * t + s + off + 3.3, perm)
        dr = w * ar * perlin1d(f * t + s + off + 7.7, perm)
        gx, gy, gz, gw = euler_yxz4(dy, dp, dr)
        _put(out_q, j, qmul4(gx, gy, gz, gw, in_q[j, 0], in_q[j, 1], in_q[j, 2], in_q[j, 3]))


@njit(cache=True, fastmath=FASTMATH)
def idle_kernel(t, seed, weight, scale, perm, in_q, in_p, out_q, out_p):  # type: ignore[no-untyped-def]
    """Perlin idle (Huang & Terzopoulos App. C): weight shift, breathing-slow trunk and head drift.

    ``weight (N,)`` is 1 for a standing body, 0 walking.
    """
    for i in range(in_q.shape[0]):
        idle_row(t, seed[i], weight[i], scale[i], perm, in_q[i], in_p[i], out_q[i], out_p[i])


GAZE_REST = 1e-6  # rad: a controller with no target and every angle below this is at rest (0)


@njit(cache=True, fastmath=FASTMATH)
def _approach(cur, target, alpha, cap, dt):  # type: ignore[no-untyped-def]
    """Exponential approach (frame-rate independent: ``alpha = 1 − exp(−dt/τ)``), then the speed cap."""
    d = (target - cur) * alpha
    lim = cap * dt
    if d > lim:
        d = lim
    elif d < -lim:
        d = -lim
    return cur + d


@njit(cache=True)
def _wrap_pi(a):  # type: ignore[no-untyped-def]
    return wrap_pi(a)


@njit(cache=True, fastmath=FASTMATH)
def gaze_alpha(dt, tau, out):  # type: ignore[no-untyped-def]
    """Per-joint approach factors ``1 − exp(−dt/τ)`` for this step (the same for every body)."""
    for k in range(tau.shape[0]):
        out[k] = 1.0 - math.exp(-dt / tau[k])


@njit(cache=True, fastmath=FASTMATH)
def gaze_at_rest(has, ang):  # type: ignore[no-untyped-def]
    """True (and the state snapped to 0) when the controller has no target and has settled: its
    shadow is then the pose itself, so the graph may skip it."""
    if has:
        return False
    for k in range(ang.shape[0]):
        if abs(ang[k, 0]) > GAZE_REST or abs(ang[k, 1]) > GAZE_REST:
            return False
    for k in range(ang.shape[0]):
        ang[k, 0] = 0.0
        ang[k, 1] = 0.0
    return True


@njit(cache=True, fastmath=FASTMATH)
def _yaw_pitch(yaw, pitch):  # type: ignore[no-untyped-def]
    """``euler_yxz4(yaw, pitch, 0)``: ``R_y(yaw) R_x(pitch)``."""
    sy, cy = sincos(0.5 * yaw)
    sp, cp = sincos(0.5 * pitch)
    return cy * sp, sy * cp, -sy * sp, cy * cp


@njit(cache=True, fastmath=FASTMATH)
def _pre_rotate(out_q, in_q, j, g):  # type: ignore[no-untyped-def]
    _put(out_q, j, qmul4(g[0], g[1], g[2], g[3], in_q[j, 0], in_q[j, 1], in_q[j, 2], in_q[j, 3]))


@row_njit(fastmath=FASTMATH)
def gaze_row(dt, has, target, head_pos, root_yaw, running, share, yaw_lim, pitch_lim, speed, alpha, ang,
             in_q, out_q, eye_l, eye_r, head_q, closed):  # type: ignore[no-untyped-def]
    """One body's gaze controller (see :func:`gaze_kernel`): ``target``, ``head_pos``, ``eye_l``,
    ``eye_r (3,)``, ``head_q (4,)``, ``ang (5, 2)`` updated in place, poses ``(J, 4)``; ``alpha``
    from :func:`gaze_alpha`."""
    for j in range(in_q.shape[0]):
        for k in range(4):
            out_q[j, k] = in_q[j, k]
    yaw_t = 0.0
    pitch_t = 0.0
    if has:
        dx = target[0] - head_pos[0]
        dy = target[1] - head_pos[1]
        dz = target[2] - head_pos[2]
        s, c = sincos(-root_yaw)
        lx = c * dx + s * dz  # R_y(-yaw) applied to d
        lz = -s * dx + c * dz
        yaw_t = math.atan2(lx, lz)
        pitch_t = math.atan2(-dy, math.hypot(lx, lz))
    eye_yaw = 0.0
    eye_pitch = 0.0
    verge_l = 0.0
    verge_r = 0.0
    loop = closed and has
    if loop:
        # The target in the head's frame, from between the eyes and from each eye.
        qx, qy, qz, qw = -head_q[0], -head_q[1], -head_q[2], head_q[3]
        mx = 0.5 * (eye_l[0] + eye_r[0])
        my = 0.5 * (eye_l[1] + eye_r[1])
        mz = 0.5 * (eye_l[2] + eye_r[2])
        hx, hy, hz = qrot3(qx, qy, qz, qw, target[0] - mx, target[1] - my, target[2] - mz)
        eye_yaw = math.atan2(hx, hz)
        eye_pitch = math.atan2(-hy, math.hypot(hx, hz))
        lx_, _, lz_ = qrot3(qx, qy, qz, qw, target[0] - eye_l[0], target[1] - eye_l[1], target[2] - eye_l[2])
        rx_, _, rz_ = qrot3(qx, qy, qz, qw, target[0] - eye_r[0], target[1] - eye_r[1], target[2] - eye_r[2])
        verge_l = _wrap_pi(math.atan2(lx_, lz_) - eye_yaw)
        verge_r = _wrap_pi(math.atan2(rx_, rz_) - eye_yaw)
    for ax in range(2):
        goal = yaw_t if ax == 0 else pitch_t
        rem = goal
        wsum = 0.0
        for k in range(4):
            wsum += share[k]
        for k in range(4):
            lim = yaw_lim[k] if ax == 0 else pitch_lim[k]
            if k < 2 and running:
                lim *= RUNNING_TORSO
            part = rem * share[k] / wsum if k < 3 else rem
            wsum -= share[k]
            part = min(max(part, -lim), lim)
            rem -= part
            ang[k, ax] = _approach(ang[k, ax], part, alpha[k], speed[k], dt)
        reached = ang[0, ax] + ang[1, ax] + ang[2, ax] + ang[3, ax]
        lim = yaw_lim[4] if ax == 0 else pitch_lim[4]
        eye = goal - reached
        if loop:
            eye = eye_yaw if ax == 0 else eye_pitch
        eye = min(max(eye, -lim), lim)
        ang[4, ax] = _approach(ang[4, ax], eye, alpha[4], speed[4], dt)
    # lumbar on Spine1, the thorax shared by Spine2 and Spine3, neck, head, then each eye
    _pre_rotate(out_q, in_q, sk.SPINE1, _yaw_pitch(ang[0, 0], ang[0, 1]))
    g = _yaw_pitch(0.5 * ang[1, 0], 0.5 * ang[1, 1])
    _pre_rotate(out_q, in_q, sk.SPINE2, g)
    _pre_rotate(out_q, in_q, sk.SPINE3, g)
    _pre_rotate(out_q, in_q, sk.NECK, _yaw_pitch(ang[2, 0], ang[2, 1]))
    _pre_rotate(out_q, in_q, sk.HEAD, _yaw_pitch(ang[3, 0], ang[3, 1]))
    _pre_rotate(out_q, in_q, sk.L_EYE, _yaw_pitch(ang[4, 0] + verge_l, ang[4, 1]))
    _pre_rotate(out_q, in_q, sk.R_EYE, _yaw_pitch(ang[4, 0] + verge_r, ang[4, 1]))


@njit(cache=True, fastmath=FASTMATH)
def gaze_kernel(dt, has_target, target, head_pos, root_yaw, running, share, yaw_lim, pitch_lim,
                speed, tau, ang, in_q, out_q, eye_l, eye_r, head_q, closed):  # type: ignore[no-untyped-def]
    """SmartBody-like gaze: lumbar → thorax → neck → head → eyes.

    The rotation toward the target (measured from the head, in the body's
    facing frame) is shared out joint by joint: each takes its share of what
    is still to go, clamped to its limits; the head takes the rest within
    its limit. Each joint approaches its target exponentially (time constant
    ``tau``) under an angular speed cap. The eyes aim at what the body
    joints have *actually* reached so far, so they lead and the head catches
    up. ``ang (N,5,2)`` (yaw, pitch) is the controller's state, updated in place.
    With no target every joint returns to 0.

    Where ``closed[i]``, the eyes close the loop instead, as the vestibulo-
    ocular reflex does: their goal is the target's direction in the head's
    frame as it actually was (``head_q (N,4)``, world, after the last forward
    kinematics) from the point between the eyes (``eye_l``, ``eye_r``
    ``(N,3)``), so the sway and bob of walking and the other choreographers'
    head motion are cancelled, not only the gaze controller's own rotations.
    Each eye then turns in by its own small angle toward the target
    (vergence), so both look at it.
    """
    alpha = np.empty(tau.shape[0])
    gaze_alpha(dt, tau, alpha)
    for i in range(in_q.shape[0]):
        gaze_row(dt, has_target[i], target[i], head_pos[i], root_yaw[i], running[i], share, yaw_lim,
                 pitch_lim, speed, alpha, ang[i], in_q[i], out_q[i], eye_l[i], eye_r[i], head_q[i], closed[i])


@njit(cache=True, fastmath=FASTMATH)
def two_bone(sx, sy, sz, tx, ty, tz, px, py, pz, l1, l2, reach, bend_forward, q1, q2):  # type: ignore[no-untyped-def]
    """Analytic two-bone IK in one frame.

    Root joint at ``s``, end target ``t``, pole ``p`` (the middle joint
    points toward it), bone lengths ``l1, l2`` along the bones' local −Y.
    Writes ``q1`` (root joint rotation in this frame) and ``q2`` (middle
    joint's local hinge rotation about X: +X bends the end backward (knee),
    −X forward (elbow), chosen by ``bend_forward``). Returns the distance
    actually reached to the target (0 when reachable).
    """
    dx, dy, dz = tx - sx, ty - sy, tz - sz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    dmax = reach * (l1 + l2)
    dmin = abs(l1 - l2) + 1e-4
    miss = 0.0
    if d > dmax:
        miss = d - dmax
    dc = min(max(d, dmin), dmax)
    if d < 1e-9:
        ux, uy, uz = 0.0, -1.0, 0.0
    else:
        ux, uy, uz = dx / d, dy / d, dz / d
    # pole component perpendicular to u
    pd = px * ux + py * uy + pz * uz
    qx, qy, qz = px - pd * ux, py - pd * uy, pz - pd * uz
    qn = math.sqrt(qx * qx + qy * qy + qz * qz)
    if qn < 1e-9:
        qx, qy, qz = 0.0, 0.0, 1.0
        pd = uz
        qx, qy, qz = -pd * ux, -pd * uy, 1.0 - pd * uz
        qn = math.sqrt(qx * qx + qy * qy + qz * qz)
    qx /= qn
    qy /= qn
    qz /= qn
    ca = (l1 * l1 + dc * dc - l2 * l2) / (2.0 * l1 * dc)
    ca = min(max(ca, -1.0), 1.0)
    sa = math.sqrt(1.0 - ca * ca)
    # first bone direction
    ax = ca * ux + sa * qx
    ay = ca * uy + sa * qy
    az = ca * uz + sa * qz
    # interior angle at the middle joint -> hinge angle
    cb = (l1 * l1 + l2 * l2 - dc * dc) / (2.0 * l1 * l2)
    cb = min(max(cb, -1.0), 1.0)
    hinge = math.pi - math.acos(cb)
    # the end bends away from the pole: local +Z of the first bone is the pole side
    # for a knee (the end swings back, -Z) and the opposite side for an elbow.
    if bend_forward:
        frame_quat(-ax, -ay, -az, -qx, -qy, -qz, q1)
        half = -0.5 * hinge
    else:
        frame_quat(-ax, -ay, -az, qx, qy, qz, q1)
        half = 0.5 * hinge
    sh, ch = sincos(half)
    q2[0] = sh
    q2[1] = 0.0
    q2[2] = 0.0
    q2[3] = ch
    return miss


@njit(cache=True, fastmath=FASTMATH)
def _qinv_mul(ax, ay, az, aw, bx, by, bz, bw):  # type: ignore[no-untyped-def]
    """a⁻¹ ∘ b for unit a."""
    return qmul4(-ax, -ay, -az, aw, bx, by, bz, bw)


@njit(cache=True, fastmath=FASTMATH)
def toe_rise(df, du, dp, rf, ru, R, pitch):  # type: ignore[no-untyped-def]
    """The heel-up pitch (≥ ``pitch``, ≤ ``PITCH_MAX``) that brings the ankle within ``R`` of the hip.

    The ankle turns about the ball on a circle: at pitch ψ it sits at ``(rf cos ψ + ru sin ψ,
    −rf sin ψ + ru cos ψ)`` (forward, up) from the ball. ``(df, du)`` is the hip from the ball in
    the foot's sagittal plane, ``dp`` its sideways offset. ``|hip − ankle|² ≤ R²`` reads
    ``A cos ψ + B sin ψ ≥ G``; the smallest such ψ above ``pitch`` on the rising side of the
    cosine, or the best pitch when none reaches (the IK then reports the miss).
    """
    a = df * rf + du * ru
    b = df * ru - du * rf
    g = 0.5 * (df * df + du * du + dp * dp + rf * rf + ru * ru - R * R)
    sp, cp = sincos(pitch)
    if a * cp + b * sp >= g:
        return pitch
    m = math.sqrt(a * a + b * b)
    phi = math.atan2(b, a)
    if phi <= pitch:
        return pitch  # rising further would only take the ankle away
    best = phi if g >= m else phi - math.acos(g / m)
    return min(max(best, pitch), PITCH_MAX)


@row_njit(fastmath=FASTMATH)
def leg_ik_row(dt, rx, rz, ry, off, foot_ref, foot_yaw, foot_pitch, foot_lift, planted, stepping, s, swing,
               h_prev, pose_q, pose_p, miss, q1, q2, anks, hips, trig, reach):  # type: ignore[no-untyped-def]
    """One body's final node (see :func:`leg_ik_kernel`); returns the new pelvis height.

    ``off (K, 3)``; the foot arrays are the body's ``(2, ...)`` rows (``foot_pitch`` may be raised in
    place); ``pose_q (J, 4)``, ``pose_p (3,)``, ``miss (2,)`` written; ``q1, q2 (4,)``, ``anks``,
    ``hips (2, 3)`` scratch.
    """
    rqy, rqw = sincos(0.5 * ry)
    rqx, rqz = 0.0, 0.0
    pqx, pqy, pqz, pqw = qmul4(rqx, rqy, rqz, rqw, pose_q[0, 0], pose_q[0, 1], pose_q[0, 2], pose_q[0, 3])
    # pelvis position in the world, height still free
    ox, oy, oz = qrot3(rqx, rqy, rqz, rqw, pose_p[0], 0.0, pose_p[2])
    pelx, pelz = rx + ox, rz + oz
    h = pose_p[1]
    heel_z = off[sk.L_HEEL, 2]
    ankle_h = -off[sk.L_HEEL, 1]
    ball_z = off[sk.L_TOE, 2]
    ball_h = ankle_h + off[sk.L_TOE, 1]
    for f in range(2):
        hipk = sk.L_HIP if f == 0 else sk.R_HIP
        # half-angle sines and cosines of each foot's yaw and pitch serve the ankle and the foot's rotation
        hs, hc = sincos(0.5 * foot_yaw[f])
        trig[f, 0], trig[f, 1] = hc * hc - hs * hs, 2.0 * hs * hc
        trig[f, 4], trig[f, 5] = hc, hs
        ps_, pc = sincos(0.5 * foot_pitch[f])
        trig[f, 2], trig[f, 3] = pc * pc - ps_ * ps_, 2.0 * ps_ * pc
        ax, ay, az = foot_pose_cs(foot_ref[f, 0], foot_ref[f, 1], trig[f, 0], trig[f, 1],
                                  foot_pitch[f] >= 0.0, trig[f, 2], trig[f, 3], foot_lift[f], heel_z, ball_z,
                                  ball_h, ankle_h)
        anks[f, 0], anks[f, 1], anks[f, 2] = ax, ay, az
        hx, hy, hz = qrot3(pqx, pqy, pqz, pqw, off[hipk, 0], off[hipk, 1], off[hipk, 2])
        hips[f, 0], hips[f, 1], hips[f, 2] = pelx + hx, hy, pelz + hz
        l1 = -off[hipk + 1, 1]
        l2 = -off[hipk + 2, 1]
        R = math.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * KNEE_MIN_COS)  # knee_reach at KNEE_MIN
        reach[f] = R
        # how much this foot constrains the pelvis height
        if planted[f]:
            w = 1.0
        elif stepping and f == swing:
            u = (s - DS) / (1.0 - DS)
            w = max(min(max((u - 0.5) / 0.5, 0.0), 1.0), 1.0 - min(max(u / 0.3, 0.0), 1.0))
        else:
            w = 0.0
        if w > 0.0:
            ddx = hips[f, 0] - ax
            ddz = hips[f, 2] - az
            top = ay + math.sqrt(max(R * R - ddx * ddx - ddz * ddz, 0.0)) - hy
            if planted[f] and foot_pitch[f] > 0.0:
                # the heel may rise further: the leg reaches at least as high as on tiptoe
                tx_, ty_, tz_ = foot_pose_cs(foot_ref[f, 0], foot_ref[f, 1], trig[f, 0], trig[f, 1], True,
                                             PITCH_MAX_COS, PITCH_MAX_SIN, 0.0, heel_z, ball_z, ball_h,
                                             ankle_h)
                ex = hips[f, 0] - tx_
                ez = hips[f, 2] - tz_
                top = max(top, ty_ + math.sqrt(max(R * R - ex * ex - ez * ez, 0.0)) - hy)
            cap = (1.0 - w) * h + w * top
            if cap < h:
                h = cap
    # never crouch to save a foot: below this the foot slides (and the metrics see it)
    h = max(h, min(pose_p[1], PELVIS_FLOOR * off[sk.PELVIS, 1]))
    h = min(h, h_prev + RISE_RATE * dt)
    pose_p[1] = h
    for f in range(2):
        hipk = sk.L_HIP if f == 0 else sk.R_HIP
        l1 = -off[hipk + 1, 1]
        l2 = -off[hipk + 2, 1]
        hx, hy, hz = hips[f, 0], hips[f, 1] + h, hips[f, 2]
        cy, sy = trig[f, 0], trig[f, 1]
        if planted[f] and foot_pitch[f] > 0.0:
            bx = foot_ref[f, 0] + ball_z * cy  # the ball, the pivot of a heel-up foot
            bz = foot_ref[f, 1] + ball_z * sy
            p = toe_rise((hx - bx) * cy + (hz - bz) * sy, hy - ball_h, (hz - bz) * cy - (hx - bx) * sy,
                         -ball_z, ankle_h - ball_h, reach[f], foot_pitch[f])
            if p != foot_pitch[f]:
                foot_pitch[f] = p
                ps_, pc = sincos(0.5 * p)
                trig[f, 2], trig[f, 3] = pc * pc - ps_ * ps_, 2.0 * ps_ * pc
                ax, ay, az = foot_pose_cs(foot_ref[f, 0], foot_ref[f, 1], cy, sy, True, trig[f, 2],
                                          trig[f, 3], 0.0, heel_z, ball_z, ball_h, ankle_h)
                anks[f, 0], anks[f, 1], anks[f, 2] = ax, ay, az
        # knee points along the foot
        miss[f] = two_bone(hx, hy, hz, anks[f, 0], anks[f, 1], anks[f, 2], cy, 0.0, sy, l1, l2, LEG_REACH,
                           False, q1, q2)
        # hip world rotation q1 -> local to the pelvis
        _put(pose_q, hipk, _qinv_mul(pqx, pqy, pqz, pqw, q1[0], q1[1], q1[2], q1[3]))
        _put(pose_q, hipk + 1, (q2[0], q2[1], q2[2], q2[3]))
        kx, ky, kz, kw = qmul4(q1[0], q1[1], q1[2], q1[3], q2[0], q2[1], q2[2], q2[3])
        # foot world rotation: yaw about +Y (3D angle φ = π/2 − yaw), then pitch about X;
        # half-angles: cos(φ/2) = (cos(yaw/2) + sin(yaw/2)) / √2, sin(φ/2) = (cos − sin) / √2
        hc, hs = trig[f, 4], trig[f, 5]
        pitch = foot_pitch[f]
        sp, cp = sincos(0.5 * pitch)
        fx_, fy_, fz_, fw_ = qmul4(0.0, (hc - hs) * _SQRT_HALF, 0.0, (hc + hs) * _SQRT_HALF, sp, 0.0, 0.0, cp)
        _put(pose_q, hipk + 2, _qinv_mul(kx, ky, kz, kw, fx_, fy_, fz_, fw_))
        tp = -pitch if pitch > 0.0 else 0.0  # toes stay flat while the heel is up
        st, ct = sincos(0.5 * tp)
        _put(pose_q, hipk + 3, (st, 0.0, 0.0, ct))
    return h


@njit(cache=True, fastmath=FASTMATH)
def leg_ik_kernel(dt, root, root_yaw, offsets, foot_ref, foot_yaw, foot_pitch, foot_lift, planted,
                  stepping, s, swing, h_prev, pose_q, pose_p, miss):  # type: ignore[no-untyped-def]
    """Final node: pelvis height from the planted feet's reach, then analytic leg IK.

    A planted foot whose heel is up (pitch > 0: late stance, push-off) may rise further onto its
    toes, up to ``PITCH_MAX``, when the leg cannot otherwise reach it from the pelvis height the
    other constraints allow; ``foot_pitch`` is updated (the gait's next frame and the swing start
    from it). This is the heel rise that keeps a walker's pelvis from dropping at push-off (the
    trailing foot is half a step and the double support behind the body there).

    ``root (N,2)`` ground root, ``root_yaw (N,)`` rotation about +Y;
    ``pose_q/pose_p`` the blended pose, updated in place (legs and pelvis
    height). ``h_prev (N,)`` the last pelvis height, updated. ``miss
    (N,2)`` is written: how far each ankle stayed from its target (0 when
    reached; a planted foot with a miss slides).
    """
    q1 = np.empty(4)
    q2 = np.empty(4)
    anks = np.empty((2, 3))
    hips = np.empty((2, 3))
    trig = np.empty((2, 6))
    reach = np.empty(2)
    for i in range(root.shape[0]):
        h_prev[i] = leg_ik_row(dt, root[i, 0], root[i, 1], root_yaw[i], offsets[i], foot_ref[i],
                               foot_yaw[i], foot_pitch[i], foot_lift[i], planted[i], stepping[i], s[i],
                               swing[i], h_prev[i], pose_q[i], pose_p[i], miss[i], q1, q2, anks, hips, trig,
                               reach)


@row_njit(fastmath=FASTMATH)
def arm_to(side, thorax_q, thorax_p, tx, ty, tz, off, pose_q, q1, q2):  # type: ignore[no-untyped-def]
    """Solve one arm of a pose ``(J, 4)`` so the hand reaches ``t``, given the thorax (Spine3) frame."""
    c = sk.L_COLLAR if side == 0 else sk.R_COLLAR
    sgn = 1.0 if side == 0 else -1.0
    # collar world
    cqx, cqy, cqz, cqw = qmul4(thorax_q[0], thorax_q[1], thorax_q[2], thorax_q[3],
                               pose_q[c, 0], pose_q[c, 1], pose_q[c, 2], pose_q[c, 3])
    ox, oy, oz = qrot3(thorax_q[0], thorax_q[1], thorax_q[2], thorax_q[3], off[c, 0], off[c, 1], off[c, 2])
    cx, cy, cz = thorax_p[0] + ox, thorax_p[1] + oy, thorax_p[2] + oz
    ox, oy, oz = qrot3(cqx, cqy, cqz, cqw, off[c + 1, 0], off[c + 1, 1], off[c + 1, 2])
    sx, sy, sz = cx + ox, cy + oy, cz + oz
    l1 = -off[c + 2, 1]
    l2 = -off[c + 3, 1] - off[c + 4, 1]  # to the hand joint
    # elbow points down, back and out, in the thorax frame
    px, py, pz = qrot3(thorax_q[0], thorax_q[1], thorax_q[2], thorax_q[3], sgn * 0.5, -1.0, -0.4)
    two_bone(sx, sy, sz, tx, ty, tz, px, py, pz, l1, l2, 0.999, True, q1, q2)
    _put(pose_q, c + 1, _qinv_mul(cqx, cqy, cqz, cqw, q1[0], q1[1], q1[2], q1[3]))
    _put(pose_q, c + 2, (q2[0], q2[1], q2[2], q2[3]))
    for j in (c + 3, c + 4):
        _put(pose_q, j, (0.0, 0.0, 0.0, 1.0))


@row_njit(fastmath=FASTMATH)
def gesture_row(t, g, start, duration, off, out_q, out_p, q1, q2, tq, tp):  # type: ignore[no-untyped-def]
    """One body's gesture clip ``g`` (see :func:`gesture_kernel`); ``tq (4,)``, ``tp (3,)`` scratch."""
    rest_pose(out_q)
    out_p[0] = 0.0
    out_p[1] = 0.0
    out_p[2] = 0.0
    if g == 0:
        return
    tau = t - start
    sc = off[sk.PELVIS, 1] / 0.98
    # thorax frame at rest: body frame, origin at Spine3
    tq[0], tq[1], tq[2], tq[3] = 0.0, 0.0, 0.0, 1.0
    tp[0] = 0.0
    tp[1] = off[sk.PELVIS, 1] + off[sk.SPINE1, 1] + off[sk.SPINE2, 1] + off[sk.SPINE3, 1]
    tp[2] = off[sk.SPINE1, 2]
    shy = tp[1] + off[sk.L_COLLAR, 1] + off[sk.L_SHOULDER, 1]
    shx = off[sk.L_COLLAR, 0] + off[sk.L_SHOULDER, 0]
    if g == G_WAVE:
        osc = 0.08 * sc * math.sin(2.0 * math.pi * 2.0 * tau)
        arm_to(1, tq, tp, -shx - 0.12 * sc + osc, shy + 0.32 * sc, 0.12 * sc, off, out_q, q1, q2)
        _put(out_q, sk.HEAD, euler_yxz4(-0.1, -0.05, 0.0))
    elif g == G_POINT:
        arm_to(1, tq, tp, -shx + 0.05 * sc, shy + 0.02 * sc, 0.62 * sc, off, out_q, q1, q2)
    elif g == G_SHRUG:
        k = math.sin(math.pi * min(max(tau / max(duration, 1e-3), 0.0), 1.0))
        for side in range(2):
            sg = 1.0 if side == 0 else -1.0
            c = sk.L_COLLAR if side == 0 else sk.R_COLLAR
            _put(out_q, c, euler_yxz4(0.0, 0.0, sg * 0.25 * k))
            _put(out_q, c + 1, euler_yxz4(0.0, -0.2 * k, sg * 0.35 * k))
            _put(out_q, c + 2, euler_yxz4(-sg * 0.4 * k, -1.3 * k, 0.0))
        _put(out_q, sk.HEAD, euler_yxz4(0.0, 0.0, 0.12 * k))
    elif g == G_PHONE:
        arm_to(1, tq, tp, -0.05 * sc, tp[1] - 0.12 * sc, 0.32 * sc, off, out_q, q1, q2)
        arm_to(0, tq, tp, 0.06 * sc, tp[1] - 0.16 * sc, 0.28 * sc, off, out_q, q1, q2)
        _put(out_q, sk.NECK, euler_yxz4(0.0, 0.25, 0.0))
        _put(out_q, sk.HEAD, euler_yxz4(0.0, 0.3, 0.0))
    elif g == G_POCKETS:
        hy = off[sk.PELVIS, 1] - 0.06 * sc
        arm_to(0, tq, tp, 0.17 * sc, hy, 0.03 * sc, off, out_q, q1, q2)
        arm_to(1, tq, tp, -0.17 * sc, hy, 0.03 * sc, off, out_q, q1, q2)
    elif g == G_TALK:
        k = 0.06 * sc * math.sin(2.0 * math.pi * 1.2 * tau)
        arm_to(1, tq, tp, -0.12 * sc, tp[1] - 0.25 * sc + k, 0.35 * sc, off, out_q, q1, q2)
        arm_to(0, tq, tp, 0.14 * sc, tp[1] - 0.3 * sc - k, 0.25 * sc, off, out_q, q1, q2)


@njit(cache=True, fastmath=FASTMATH)
def gesture_kernel(t, kind, start, duration, offsets, out_q, out_p):  # type: ignore[no-untyped-def]
    """Gesture clips on the upper body (a generator: posed in the body frame).

    Hand targets are relative to the thorax, so a clip follows the trunk
    wherever the blend puts it. ``kind (N,)`` (``G_*``), ``start``/``duration (N,)`` s.
    """
    q1 = np.empty(4)
    q2 = np.empty(4)
    tq = np.empty(4)
    tp = np.empty(3)
    for i in range(kind.shape[0]):
        gesture_row(t, kind[i], start[i], duration[i], offsets[i], out_q[i], out_p[i], q1, q2, tq, tp)


@row_njit(fastmath=FASTMATH)
def reach_row(active, target, thorax_q, thorax_p, off, in_q, out_q, q1, q2):  # type: ignore[no-untyped-def]
    """One body's reach over ``in`` (see :func:`reach_kernel`); ``active (2,)``, ``target (2, 3)``."""
    for j in range(in_q.shape[0]):
        for k in range(4):
            out_q[j, k] = in_q[j, k]
    for side in range(2):
        if active[side]:
            t = target[side]
            arm_to(side, thorax_q, thorax_p, t[0], t[1], t[2], off, out_q, q1, q2)


@njit(cache=True, fastmath=FASTMATH)
def reach_kernel(active, target, world_pos, world_q, offsets, in_q, out_q):  # type: ignore[no-untyped-def]
    """Reach (transformer): per agent and arm, put the hand at ``target (N,2,3)`` (world).

    ``world_pos/world_q`` are the FK of the input pose (thorax frame).
    """
    q1 = np.empty(4)
    q2 = np.empty(4)
    for i in range(in_q.shape[0]):
        reach_row(active[i], target[i], world_q[i, sk.SPINE3], world_pos[i, sk.SPINE3], offsets[i], in_q[i],
                  out_q[i], q1, q2)


# -- blend nodes ----------------------------------------------------------------------------------

@njit(cache=True, fastmath=FASTMATH)
def blend_joint(pose_q, shadow_q, j, w):  # type: ignore[no-untyped-def]
    """``pose_q[j] ← normalize((1−w)·pose + w·shadow)``, both put in the hemisphere ``w ≥ 0``.

    At full weight that is the shadow's (unit) rotation in that hemisphere, copied as it is.
    """
    sb = 1.0 if shadow_q[j, 3] >= 0.0 else -1.0
    if w >= 1.0:
        for k in range(4):
            pose_q[j, k] = sb * shadow_q[j, k]
        return
    sa = 1.0 if pose_q[j, 3] >= 0.0 else -1.0
    nn = 0.0
    for k in range(4):
        v = (1.0 - w) * sa * pose_q[j, k] + w * sb * shadow_q[j, k]
        pose_q[j, k] = v
        nn += v * v
    nn = math.sqrt(nn)
    for k in range(4):
        pose_q[j, k] /= nn


@njit(cache=True, fastmath=FASTMATH)
def blend_row(pose_q, pose_p, shadow_q, shadow_p, w, mask, mask_pelvis_pos):  # type: ignore[no-untyped-def]
    """One body's two-input blend node (see :func:`blend_kernel`); ``mask (J,)``."""
    if w <= 0.0:
        return
    for j in range(pose_q.shape[0]):
        if mask[j]:
            blend_joint(pose_q, shadow_q, j, w)
    if mask_pelvis_pos:
        for k in range(3):
            pose_p[k] = (1.0 - w) * pose_p[k] + w * shadow_p[k]


@njit(cache=True, fastmath=FASTMATH)
def blend_rows_kernel(pose_q, shadow_q, weight, row_mask):  # type: ignore[no-untyped-def]
    """:func:`blend_kernel` with a joint mask per agent ``row_mask (N, J)`` (rotations only)."""
    for i in range(pose_q.shape[0]):
        w = weight[i]
        if w <= 0.0:
            continue
        for j in range(pose_q.shape[1]):
            if row_mask[i, j]:
                blend_joint(pose_q[i], shadow_q[i], j, w)


@njit(cache=True, fastmath=FASTMATH)
def blend_kernel(pose_q, pose_p, shadow_q, shadow_p, weight, mask, mask_pelvis_pos):  # type: ignore[no-untyped-def]
    """Two-input blend node, in place: ``pose ← (1−w)·pose + w·shadow`` on masked joints.

    Quaternions are put in the hemisphere ``w ≥ 0`` before the weighted sum
    and normalized after, so the result does not depend on input order.
    """
    for i in range(pose_q.shape[0]):
        blend_row(pose_q[i], pose_p[i], shadow_q[i], shadow_p[i], weight[i], mask, mask_pelvis_pos)


@njit(cache=True, fastmath=FASTMATH)
def blend_many(qs, ws, out):  # type: ignore[no-untyped-def]
    """Multi-input blend node: ``out (N,J,4) = normalize(Σ_m w_m · q_m)``, hemisphere w ≥ 0."""
    m = qs.shape[0]
    n = qs.shape[1]
    nj = qs.shape[2]
    acc = np.zeros(4)
    for i in range(n):
        for j in range(nj):
            acc[:] = 0.0
            for c in range(m):
                sg = 1.0 if qs[c, i, j, 3] >= 0.0 else -1.0
                for k in range(4):
                    acc[k] += ws[c, i] * sg * qs[c, i, j, k]
            nn = math.sqrt(acc[0] ** 2 + acc[1] ** 2 + acc[2] ** 2 + acc[3] ** 2)
            for k in range(4):
                out[i, j, k] = acc[k] / nn if nn > 0.0 else (1.0 if k == 3 else 0.0)
