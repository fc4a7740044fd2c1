"""Footstep-based procedural walking (PedVR §3.4/§4.1 coupling; Huang & Terzopoulos App. C).

Everything here is in 2D ground coordinates (x, y) plus a height; the pose
module lifts it to 3D. A foot is described by its *ground reference* (the
point under the ankle when the foot is flat), its yaw (a 2D heading) and
its pitch ψ (positive: heel up, rotating about the ball joint; negative:
toes up, rotating about the heel contact). A *planted* foot's reference and
yaw never change while it is planted: that is why the coupled mode does not
skate.

Gait (coupled mode, and the user's body). A step starts when the swing foot
leaves the double support: the previous stance foot stays planted (heel
rising) for ``DS`` of the step, swings on a lift curve, and lands at ``s = 1``
where it becomes the stance foot. The landing target is re-planned every
frame from the root's current velocity (speed changes within a stride):
``landing = root + v·τ + v·T/2 + lateral``, τ the time left in the step
(negative on the landing frame, by the part of the frame the root moved past
touchdown: clamping it to 0 used to drag the descending heel 1–1.5 cm), T the
step duration from the step rate. As the foot comes down it commits to its
landing: between ``COMMIT_FROM`` and ``COMMIT_TO`` of the swing the target it
steers to stops following the re-planned one, so a late change of velocity
does not slide a heel that is already at the floor. The landing is kept at
least ``MIN_WIDTH`` to its own side of the stance foot (no crossing over), at
most ``MAX_WIDTH`` sideways and ``MAX_BACK`` behind it, and within
``MAX_STEP``. Standing, a step is taken when a foot is more than
``RESTEP_DIST`` or ``RESTEP_YAW`` away from where it should stand (turning on
the spot, small shuffles); walking starts when the root moves faster than
``V_WALK`` and stops, with the feet together, when it slows below it.

Short repositions (PLACE §5: "short-range repositioning in 2–4 steps"). Our
reading: side or back-side steps whose last, closing step ends the
reposition. A lead side step is planned for a body that keeps moving, so when
the body brakes (the demonstrator's profile) it lands past its place beside
where the body stops; squaring that would be a fifth step. So a side step
closing toward such a lead foot (:func:`side_closing`: more inward than along
the facing, more than ``MIN_WIDTH``) lands abreast of it and as far to its
own side of the stopping point, and that *wide stance* (:func:`wide_stance`:
abreast, the root midway, wider than the hip and at most ``STANCE_MAX``,
about shoulder width, apart) is kept while standing. A body braking while
moving more than 60° off its facing (side or back stepping) plans its
landings ``v / 2|a|`` s ahead, where it will stop, rather than ``τ + T/2``.
Forward walking and its stops, turning on the spot and shuffles are
unchanged: their steps are not side closing ones, so their feet end beside
the root as before (a stance wider than the hip lowers the pelvis, and a
pram pusher's hands would leave the handle). Repositions of up to about
0.6 m take 2–4 steps; longer ones take more.

Step rate: walking forward ``f = F0 · (v / 1.35)^k · scale^-0.35`` steps/s
(``k`` = 0.26 below 1.35 m/s, 0.6 above; clamped to ``[F_MIN, F_MAX]``),
step length = v / f: 1.8–2.1 steps/s and 0.65–0.78 m steps at 1.3–1.4 m/s
for heights 1.55–1.95 m, about 1.5 steps/s at 0.5 m/s and 2.3 at 1.8 m/s, as
people walk. Moving mostly sideways the body side-steps, advancing
``SIDE_ADVANCE`` per step (short steps, the leading foot first, the trailing
one closing), and backward it takes ``BACK_STEP`` steps, both up to
``F_SIDE_MAX`` steps/s (:func:`step_rate`). A body that is speeding up steps
at the rate of the speed it is reaching (``ACC_AHEAD``, ``T_AHEAD``).

First step from standing (Huang & Terzopoulos App. C, Fig. 20(d): "the
first step is generated closer to the initial foot position", α = 1.0
against 1.5 walking). Our interpretation: H&T plan a whole step sequence
from a root that moves with the steps; here the root is the steered body and
is already accelerating when the first foot leaves, so "closer" is a
*quicker* first step: it lasts at most ``T_START`` and ``START_FRAC`` of a
walking step, and lands ``LEAD_START`` times the walking lead past the root.
At the default 1.5 m/s² to 1.35 m/s the first step is 0.45 m, about the
paper's 1.0 / 1.5 of a 0.7 m walking step, and the next ones 0.70, 0.72,
0.70 m (no lunge, no extra pelvis drop). Starting sideways, the leading foot
steps first (the swing foot may still be changed while both feet are down).

Decoupled mode (the study baseline): the root follows the disc rigidly and
the legs play a cycle authored at ``V_CLIP`` in the root's frame, its
playback rate scaled by speed but clamped to ``[RATE_MIN, RATE_MAX]`` (as
animation blending does); turning rotates the planted feet with the root,
contact pushes drag them, slow walking slides them. The same contact flags
and metrics apply to both modes.
"""

from __future__ import annotations

import math

from numba import njit

from pedvr.body.quat import FASTMATH
from pedvr.crowd.state import LIMIT_BACKWARD, LIMIT_TURN_WALKING
from pedvr.kernels import wrap_pi

F0 = 1.93  # steps/s at V_REF for the 1.75 m reference adult
V_REF = 1.35  # m/s
K_SLOW, K_FAST = 0.26, 0.6  # cadence exponents below and above V_REF
F_MIN, F_MAX = 1.3, 2.6
SIDE_ADVANCE = 0.16  # m (reference adult): the body's sideways progress per side step
BACK_STEP = 0.3  # m (reference adult): step length walking backward
F_SIDE_MAX = 3.2  # steps/s: fastest side or back stepping
V_WALK = 0.12  # m/s: below this the body stands (and steps only to re-square its feet)
T_INPLACE = 0.55  # s: duration of a step taken standing (turn on the spot, shuffle)
ACC_AHEAD, T_AHEAD = 2.0, 0.25  # m/s², s: how far ahead the step rate anticipates a speed-up
LEAD_START = 1.25  # the first step lands this much farther past the root than a walking step does
START_FRAC = 0.7  # nor longer than this fraction of a walking step at the speed being reached
T_START = 0.5  # s (reference adult): the first step from standing into a walk
DS = 0.2  # fraction of a step in double support
MIN_WIDTH = 0.1  # m (reference adult): swing foot lands at least this far to its own side of the stance foot
MAX_STEP = 0.8  # m (reference adult): farthest landing from the stance foot
MAX_WIDTH = 0.5  # m (reference adult): farthest landing sideways from the stance foot (short side steps)
MAX_BACK = 0.45  # m (reference adult): farthest landing behind the stance foot (short back steps)
LIFT_WALK = 0.085  # m (reference adult): swing-foot clearance at a walk
LIFT_STEP = 0.05  # m: clearance of a step taken standing
PEAK_AT = 0.4  # fraction of the swing where the foot is highest (Ashida Fig. 6)
HEEL_STRIKE = 0.35  # rad (20°): toes up at heel strike
HEEL_MID = 0.35  # rad (20°): heel lift of the stance foot at the other foot's heel strike
TOE_OFF = 0.6  # rad (35°): heel lift at toe-off
HEEL_ROCKER = 0.1  # s: heel strike to foot flat
TOE_OUT = 0.09  # rad (5°): feet point slightly outward
HURRY_AT = 0.08  # m (reference adult): a planted foot this much farther from the root than the
# gait puts it (half a step behind plus the hip width) hurries the step, or lifts a trailing foot early
FAR = 0.46  # m (reference adult): a stance foot never waits farther than this from the root
FAR_TRAIL = 0.56  # m: nor a trailing foot (heel up, its ankle higher and nearer)
RESTEP_DIST = 0.07  # m (reference adult)
RESTEP_YAW = 0.35  # rad
STANCE_MAX = 0.38  # m (reference adult): a wide stance's feet at most this far apart (about shoulder width)
V_CLIP = 1.35  # m/s: speed the decoupled cycle was "authored" at
RATE_MIN, RATE_MAX = 0.5, 1.5
VEL_SMOOTH = 0.08  # s: time constant of the velocity the planner uses (contact jitter)
COMMIT_FROM, COMMIT_TO = 0.7, 0.95  # fractions of the swing over which the landing target is committed

LEFT, RIGHT = 0, 1


@njit(cache=True, fastmath=FASTMATH, inline="always")
def cadence(speed, scale):  # type: ignore[no-untyped-def]
    """Forward walking, steps/s: ``F0 (v / V_REF)^k scale^-0.35``, ``k = K_SLOW`` below V_REF,
    ``K_FAST`` above, clamped to ``[F_MIN, F_MAX]``."""
    v = max(speed, 1e-3)
    k = K_SLOW if v < V_REF else K_FAST
    f = F0 * (v / V_REF) ** k * scale ** -0.35
    return min(max(f, F_MIN), F_MAX)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def step_rate(fwd, lat, speed, scale):  # type: ignore[no-untyped-def]
    """Steps/s for a body moving ``fwd`` m/s along its facing and ``lat`` m/s to its left.

    Mostly sideways, a body side-steps: the trailing foot closes and the leading one steps out,
    the body advancing ``SIDE_ADVANCE`` per step, so the feet stay at most about ``MIN_WIDTH +
    2 SIDE_ADVANCE`` apart; backward it takes ``BACK_STEP`` steps; both no faster than ``F_SIDE_MAX``.
    Diagonal walking blends in the side rule only beyond about 30° off the facing.
    """
    f = cadence(speed, scale)
    if speed > 1e-9:
        w = ease((abs(lat) / speed - 0.5) / 0.4)
        f = max(f, w * min(abs(lat) / (SIDE_ADVANCE * scale), F_SIDE_MAX))
    if fwd < 0.0:
        f = max(f, min(-fwd / (BACK_STEP * scale), F_SIDE_MAX))
    return f


@njit(cache=True, fastmath=FASTMATH, inline="always")
def wrap(a):  # type: ignore[no-untyped-def]
    return wrap_pi(a)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def ease(u):  # type: ignore[no-untyped-def]
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def lift_curve(u):  # type: ignore[no-untyped-def]
    """Swing height profile in [0, 1], peak at ``PEAK_AT`` of the swing."""
    u = min(max(u, 0.0), 1.0)
    g = math.log(0.5) / math.log(PEAK_AT)
    return math.sin(math.pi * u ** g)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def stand_ref(rx, ry, heading, side, half_width):  # type: ignore[no-untyped-def]
    """Where a foot stands: beside the root, anatomical left is 2D heading − π/2."""
    lx, ly = math.sin(heading), -math.cos(heading)
    sgn = 1.0 if side == LEFT else -1.0
    return rx + sgn * half_width * lx, ry + sgn * half_width * ly


@njit(cache=True, fastmath=FASTMATH, inline="always")
def stance_offset(x, y, rx, ry, heading, side):  # type: ignore[no-untyped-def]
    """A foot at ``(x, y)`` in the frame of a root at ``(rx, ry)``: how far (m) it is to its own side
    (``side``) of the root, and how far ahead of it."""
    dx, dy = x - rx, y - ry
    sgn = 1.0 if side == LEFT else -1.0
    ch, sh = math.cos(heading), math.sin(heading)
    return sgn * (dx * sh - dy * ch), dx * ch + dy * sh


@njit(cache=True, fastmath=FASTMATH, inline="always")
def wide_stance(w_a, lon_a, w_b, lon_b, half_width, scale):  # type: ignore[no-untyped-def]
    """Whether two feet, ``w`` m to their own sides of the root and ``lon`` m ahead of it, stand in a
    wide stance the gait keeps (a short reposition's closing side step leaves one): abreast, the root
    midway between them, between hip width and ``STANCE_MAX`` apart, within ``RESTEP_DIST`` ahead of
    or behind the root. Feet at hip width beside the root are the usual stance, not a wide one."""
    tol = 0.25 * RESTEP_DIST * scale
    return abs(lon_a - lon_b) < tol and abs(w_a - w_b) < tol and min(w_a, w_b) > half_width and \
        max(w_a, w_b) <= 0.5 * STANCE_MAX * scale and abs(lon_a + lon_b) < 2.0 * RESTEP_DIST * scale


@njit(cache=True, fastmath=FASTMATH, inline="always")
def side_closing(ox, oy, tx, ty, heading, side, scale):  # type: ignore[no-untyped-def]
    """Whether a swing of foot ``side`` from ``(ox, oy)`` to ``(tx, ty)`` is a side step closing toward
    the other foot: more than ``MIN_WIDTH`` inward, and more inward than along the facing (so not a
    squaring shuffle, nor a forward or back step)."""
    inward, along = stance_offset(ox, oy, tx, ty, heading, side)
    return inward > max(abs(along), MIN_WIDTH * scale)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def foot_yaw_for(heading, side):  # type: ignore[no-untyped-def]
    return heading - TOE_OUT if side == LEFT else heading + TOE_OUT


@njit(cache=True, fastmath=FASTMATH)
def gait_kernel(coupled, dt, t, root, root_prev, heading, is_user, scale, half_width,
                vel_s, stepping, s, swing, foot_ref, foot_yaw, foot_pitch, foot_lift,
                since_land, lift_ref, lift_yaw, lift_pitch, trail_pitch0, roll, phase, amp, planted,
                land, first, step_events, n_events):  # type: ignore[no-untyped-def]
    """Advance every body's feet one step of ``dt`` given its final root.

    ``root (N,2)`` is where the root is after this step (the contact pass
    included), ``root_prev (N,2)`` where it was; ``heading (N,)`` the body's
    facing. State arrays are updated in place (this kernel *is* the commit
    of the gait state; it reads nothing else that changes). ``planted
    (N,2)`` is written: 1 where a foot is on the ground. ``land (N,3)`` is
    the swing foot's committed landing (x, y, yaw); ``first (N,)`` marks a
    step that began from standing. Completed steps are
    appended to ``step_events (M,4)`` as ``(row, duration s, root distance m,
    mean speed m/s)``; the count is returned (rows past the capacity are dropped).
    """
    n = root.shape[0]
    ne = n_events
    a_v = 1.0 - math.exp(-dt / VEL_SMOOTH)
    for i in range(n):
        sc = scale[i]
        hw = half_width[i]
        vx = (root[i, 0] - root_prev[i, 0]) / dt
        vy = (root[i, 1] - root_prev[i, 1]) / dt
        vel_s[i, 0] += (vx - vel_s[i, 0]) * a_v
        vel_s[i, 1] += (vy - vel_s[i, 1]) * a_v
        svx, svy = vel_s[i, 0], vel_s[i, 1]
        speed = math.sqrt(svx * svx + svy * svy)
        h = heading[i]
        fx, fy = math.cos(h), math.sin(h)
        fwd_speed = svx * fx + svy * fy
        lat_speed = svx * fy - svy * fx  # toward the anatomical left, 2D (sin h, -cos h)
        # Heel-toe roll grows with forward speed; steps back or sideways are flat-footed.
        roll_t = min(max(fwd_speed / 1.0, 0.0), 1.0)
        roll[i] += (roll_t - roll[i]) * (1.0 - math.exp(-dt / 0.2))
        amp_t = min(speed / 1.3, 1.3)
        amp[i] += (amp_t - amp[i]) * (1.0 - math.exp(-dt / 0.25))
        walking = speed > V_WALK
        acc = 0.0  # m/s², the smoothed velocity's rate of change along itself (coupled mode)
        if coupled or is_user[i]:
            # A body speeding up steps at the rate of the speed it is reaching (the smoothed velocity
            # lags the raw one by acceleration × VEL_SMOOTH), so its early steps are not drawn out.
            ahead = speed
            if speed > 1e-9:
                acc = ((vx - svx) * svx + (vy - svy) * svy) / (speed * VEL_SMOOTH)
            ahead = speed + min(max(acc, 0.0), ACC_AHEAD) * T_AHEAD
            T = 1.0 / step_rate(fwd_speed * ahead / max(speed, 1e-9), lat_speed * ahead / max(speed, 1e-9),
                                ahead, sc) if walking else T_INPLACE
        else:
            T = 1.0 / cadence(V_CLIP, sc)
        if not (coupled or is_user[i]):
            # ---- decoupled: a cycle in the root frame, playback rate clamped.
            rate = min(max(speed / V_CLIP, RATE_MIN), RATE_MAX) if walking else 0.0
            if walking:
                stepping[i] = True
            s_old = s[i]
            s[i] += rate * dt / T
            if s[i] >= 1.0:
                s[i] -= 1.0
                swing[i] = 1 - swing[i]
                since_land[i, 1 - swing[i]] = 0.0
                if ne < step_events.shape[0]:
                    step_events[ne, 0] = i
                    step_events[ne, 1] = T / max(rate, 1e-9)
                    step_events[ne, 2] = speed * T / max(rate, 1e-9)
                    step_events[ne, 3] = speed
                    ne += 1
            L = V_CLIP * T
            lx, ly = math.sin(h), -math.cos(h)
            for f in range(2):
                sgn = 1.0 if f == LEFT else -1.0
                st = 1 - swing[i]
                if not walking and not stepping[i]:
                    z = 0.0
                    lift = 0.0
                    pitch = 0.0
                    planted[i, f] = 1
                elif f == st:
                    z = L * (0.5 - s[i])
                    lift = 0.0
                    pitch = HEEL_MID * ease((s[i] - 0.55) / 0.45) - HEEL_STRIKE * (1.0 - ease(s[i] / 0.15))
                    planted[i, f] = 1
                elif s[i] < DS:
                    z = -L * (0.5 + s[i])
                    lift = 0.0
                    pitch = HEEL_MID + (TOE_OFF - HEEL_MID) * ease(s[i] / DS)
                    planted[i, f] = 1
                else:
                    u = (s[i] - DS) / (1.0 - DS)
                    e = ease(u)
                    z = -L * (0.5 + DS) + L * (1.0 + DS) * e
                    lift = LIFT_WALK * sc * lift_curve(u)
                    pitch = TOE_OFF * (1.0 - e) - HEEL_STRIKE * e
                    planted[i, f] = 0
                if not walking:
                    # The cycle freezes; the feet blend back under the body, sliding.
                    if stepping[i]:
                        stepping[i] = False
                    k = 1.0 - math.exp(-dt / 0.15)
                    tx = root[i, 0] + sgn * hw * lx
                    ty = root[i, 1] + sgn * hw * ly
                    foot_ref[i, f, 0] += (tx - foot_ref[i, f, 0]) * k
                    foot_ref[i, f, 1] += (ty - foot_ref[i, f, 1]) * k
                    foot_pitch[i, f] *= 1.0 - k
                    foot_lift[i, f] *= 1.0 - k
                    foot_yaw[i, f] = foot_yaw_for(h, f)
                    planted[i, f] = 1
                else:
                    foot_ref[i, f, 0] = root[i, 0] + z * fx + sgn * hw * lx
                    foot_ref[i, f, 1] = root[i, 1] + z * fy + sgn * hw * ly
                    foot_pitch[i, f] = pitch * roll[i]
                    foot_lift[i, f] = lift
                    foot_yaw[i, f] = foot_yaw_for(h, f)
                since_land[i, f] += dt
            phase[i] = math.pi * (s[i] + (1.0 if (1 - swing[i]) == RIGHT else 0.0))
            continue

        # ---- coupled: footsteps in the world, planted feet pinned.
        since_land[i, 0] += dt
        since_land[i, 1] += dt
        if not stepping[i]:
            worst = 0.0
            pick = -1
            # a wide stance left by a closing side step holds while its feet stay abreast about the root
            px, py = root[i, 0] + svx * T, root[i, 1] + svy * T
            w_l, lon_l = stance_offset(foot_ref[i, LEFT, 0], foot_ref[i, LEFT, 1], px, py, h, LEFT)
            w_r, lon_r = stance_offset(foot_ref[i, RIGHT, 0], foot_ref[i, RIGHT, 1], px, py, h, RIGHT)
            wide = wide_stance(w_l, lon_l, w_r, lon_r, hw, sc)
            for f in range(2):
                tx, ty = stand_ref(px, py, h, f, hw)
                d = math.hypot(foot_ref[i, f, 0] - tx, foot_ref[i, f, 1] - ty)
                if wide:
                    d = abs(lon_l if f == LEFT else lon_r)
                dyaw = abs(wrap(foot_yaw[i, f] - foot_yaw_for(h, f)))
                err = d / (RESTEP_DIST * sc) + dyaw / RESTEP_YAW
                if err > worst:
                    worst = err
                    pick = f
            if walking or worst > 1.0:
                stepping[i] = True
                s[i] = 0.0
                swing[i] = pick
                first[i] = True
        if stepping[i] and first[i] and walking and s[i] < DS and abs(lat_speed) > 0.5 * speed:
            # Starting sideways: the leading foot steps out first, the trailing one then closes (it
            # may not cross over). Both feet are still down, so the choice can still change.
            lead = LEFT if lat_speed > 0.0 else RIGHT
            if swing[i] != lead:
                swing[i] = lead
                trail_pitch0[i] = foot_pitch[i, lead]
        if stepping[i]:
            sw = swing[i]
            st = 1 - sw
            T_nom = T
            if first[i] and walking:
                # Huang & Terzopoulos App. C: from standing the first step is generated closer to the
                # feet (alpha 1.0 against 1.5 walking). Here the body's root is already accelerating, so
                # "closer" is a quick first step: it lands before the root has run far, about 2/3 of a
                # steady step at the usual acceleration, and the second step is about a steady one.
                T = min(T, T_START * sc ** 0.35, START_FRAC * T)
            # a stance foot left far behind (a push, a sharp turn) hurries the step
            dst = math.hypot(foot_ref[i, st, 0] - root[i, 0], foot_ref[i, st, 1] - root[i, 1])
            l_nom = speed * T_nom
            over = (dst - min(0.5 * l_nom + hw + HURRY_AT * sc, FAR * sc)) / (0.1 * sc)
            if over > 0.0:
                T = T / min(1.0 + 4.0 * over, 5.0)
            s_old = s[i]
            if s_old <= 0.0:
                trail_pitch0[i] = foot_pitch[i, sw]
            s[i] += dt / T
            if s[i] < DS:
                # the trailing foot lifts early when the body has run ahead of it
                dtr = math.hypot(foot_ref[i, sw, 0] - root[i, 0], foot_ref[i, sw, 1] - root[i, 1])
                if dtr > min((0.5 + DS) * l_nom + hw + HURRY_AT * sc, FAR_TRAIL * sc):
                    s[i] = DS
            if s_old < DS <= s[i]:
                lift_ref[i, 0] = foot_ref[i, sw, 0]
                lift_ref[i, 1] = foot_ref[i, sw, 1]
                lift_yaw[i] = foot_yaw[i, sw]
                lift_pitch[i] = foot_pitch[i, sw]
            # Time to touchdown; negative on the landing frame, where s overshoots 1 by the part of
            # the frame the body moved past it (clamping it to 0 moved the target by that much).
            tau = (1.0 - s[i]) * T
            # Landing target from the current velocity (re-planned every frame).
            lead = 0.5 * T_nom
            if first[i] and walking:
                lead *= LEAD_START
            ahead_t = tau + lead
            if walking and acc < 0.0 and fwd_speed < 0.5 * speed:
                # side / back stepping and braking: the root runs on about v / 2|a| s more, not tau + lead
                ahead_t = min(ahead_t, 0.5 * speed / -acc)
            px = root[i, 0] + svx * ahead_t
            py = root[i, 1] + svy * ahead_t
            tx, ty = stand_ref(px, py, h, sw, hw)
            lx, ly = math.sin(h), -math.cos(h)
            sgn = 1.0 if sw == LEFT else -1.0
            w_st, lon_st = stance_offset(foot_ref[i, st, 0], foot_ref[i, st, 1], px, py, h, st)
            ox, oy = foot_ref[i, sw, 0], foot_ref[i, sw, 1]  # where the swing started (or starts)
            if s[i] >= DS:
                ox, oy = lift_ref[i, 0], lift_ref[i, 1]
            if side_closing(ox, oy, tx, ty, h, sw, sc) and wide_stance(w_st, lon_st, w_st, lon_st, hw, sc):
                # PLACE §5, short-range repositioning in 2-4 steps: a side step closing toward a lead foot
                # that stepped out past its place beside where the body stops (it was planned for a body
                # that kept moving, which then braked), by no more than a wide stance allows, lands
                # abreast of it and as far to its own side: the reposition ends on its closing step, not
                # with a squaring shuffle. Forward and back stops, and shuffles, close as before.
                tx = px + sgn * w_st * lx + lon_st * fx
                ty = py + sgn * w_st * ly + lon_st * fy
            # In the body's frame about the stance foot: stay on its own side (no crossing over),
            # side steps no wider than MAX_WIDTH, back steps no longer than MAX_BACK, any step no
            # longer than MAX_STEP.
            ax, ay = foot_ref[i, st, 0], foot_ref[i, st, 1]
            lat = (tx - ax) * lx + (ty - ay) * ly
            lon = (tx - ax) * fx + (ty - ay) * fy
            lat = sgn * min(max(sgn * lat, MIN_WIDTH * sc), MAX_WIDTH * sc)
            lon = max(lon, -MAX_BACK * sc)
            dd = math.hypot(lat, lon)
            lim = MAX_STEP * sc
            if dd > lim:
                lat *= lim / dd
                lon *= lim / dd
            tx = ax + lat * lx + lon * fx
            ty = ay + lat * ly + lon * fy
            tyaw = foot_yaw_for(h, sw)
            # The foot commits to its landing as it comes down: the target it steers to follows the
            # re-planned one fully until COMMIT_FROM of the swing and not at all after COMMIT_TO, so a
            # change of velocity in the last instants no longer drags the descending heel along.
            if s[i] < DS:
                k = 1.0
            else:
                k = 1.0 - ease(((s[i] - DS) / (1.0 - DS) - COMMIT_FROM) / (COMMIT_TO - COMMIT_FROM))
            if s_old < DS:
                k = 1.0  # the swing starts from the plan as it stands
            land[i, 0] += (tx - land[i, 0]) * k
            land[i, 1] += (ty - land[i, 1]) * k
            land[i, 2] += wrap(tyaw - land[i, 2]) * k
            tx, ty, tyaw = land[i, 0], land[i, 1], land[i, 2]
            r = roll[i]
            # stance foot: heel rocker after landing, then the heel rises
            hs = -HEEL_STRIKE * r * (1.0 - ease(since_land[i, st] / HEEL_ROCKER))
            ho = HEEL_MID * r * ease((s[i] - 0.55) / 0.45) if walking else 0.0
            foot_pitch[i, st] = hs if hs < -1e-9 else ho
            planted[i, st] = 1
            if s[i] < DS:
                # trailing foot: still planted, heel rising toward toe-off
                p0 = max(trail_pitch0[i], 0.0)
                target = max(TOE_OFF * r, p0) if walking else p0
                foot_pitch[i, sw] = p0 + (target - p0) * ease(s[i] / DS)
                planted[i, sw] = 1
                foot_lift[i, sw] = 0.0
            elif s[i] < 1.0:
                u = (s[i] - DS) / (1.0 - DS)
                e = ease(u)
                foot_ref[i, sw, 0] = lift_ref[i, 0] + (tx - lift_ref[i, 0]) * e
                foot_ref[i, sw, 1] = lift_ref[i, 1] + (ty - lift_ref[i, 1]) * e
                foot_yaw[i, sw] = lift_yaw[i] + wrap(tyaw - lift_yaw[i]) * e
                travel = math.hypot(tx - lift_ref[i, 0], ty - lift_ref[i, 1])
                clear = LIFT_STEP * sc + (LIFT_WALK - LIFT_STEP) * sc * min(1.0, travel / (0.8 * sc))
                foot_lift[i, sw] = clear * lift_curve(u)
                foot_pitch[i, sw] = lift_pitch[i] * (1.0 - e) - HEEL_STRIKE * r * e
                planted[i, sw] = 0
            else:
                # heel strike: the swing foot lands and becomes the stance foot
                foot_ref[i, sw, 0] = tx
                foot_ref[i, sw, 1] = ty
                foot_yaw[i, sw] = tyaw
                foot_lift[i, sw] = 0.0
                foot_pitch[i, sw] = -HEEL_STRIKE * r
                since_land[i, sw] = 0.0
                planted[i, sw] = 1
                if ne < step_events.shape[0] and walking:
                    # the stance foot landed when this step began: its time down is the step's duration
                    step_events[ne, 0] = i
                    step_events[ne, 1] = since_land[i, st]
                    step_events[ne, 2] = speed * since_land[i, st]
                    step_events[ne, 3] = speed
                    ne += 1
                # another step? the other foot is now behind, or the body still moves
                ox, oy = stand_ref(root[i, 0], root[i, 1], h, st, hw)
                d = math.hypot(foot_ref[i, st, 0] - ox, foot_ref[i, st, 1] - oy)
                dyaw = abs(wrap(foot_yaw[i, st] - foot_yaw_for(h, st)))
                # stopped in a wide stance (a closing side step's, above): nothing to square
                rx, ry = root[i, 0], root[i, 1]
                w_st, lon_st = stance_offset(foot_ref[i, st, 0], foot_ref[i, st, 1], rx, ry, h, st)
                w_sw, lon_sw = stance_offset(tx, ty, rx, ry, h, sw)
                closed = not walking and wide_stance(w_st, lon_st, w_sw, lon_sw, hw, sc)
                if walking or (d > 0.5 * RESTEP_DIST * sc and not closed) or dyaw > 0.5 * RESTEP_YAW:
                    s[i] = s[i] - 1.0 if walking else 0.0
                    swing[i] = st
                    trail_pitch0[i] = foot_pitch[i, st]
                    first[i] = not walking
                else:
                    stepping[i] = False
                    s[i] = 0.0
        else:
            for f in range(2):
                planted[i, f] = 1
                foot_lift[i, f] = 0.0
                # standing: a heel still up comes down, a toe still up comes down
                if foot_pitch[i, f] != 0.0:
                    k = 1.0 - math.exp(-dt / 0.08)
                    foot_pitch[i, f] *= 1.0 - k
                    if abs(foot_pitch[i, f]) < 1e-4:
                        foot_pitch[i, f] = 0.0
        st = 1 - swing[i]
        phase[i] = math.pi * (s[i] + (1.0 if st == RIGHT else 0.0))
    return ne


@njit(cache=True, fastmath=FASTMATH)
def limits_kernel(base, stepping, s, vel, heading, pref_speed, is_user, out):  # type: ignore[no-untyped-def]
    """Motion limits ``out (N,6)`` for this step from the profile's ``base (N,6)`` (see
    :meth:`pedvr.body.model.FullBody.fill_limits`): the walking turn rate 80 % mid-swing, stepping
    back down to 40 % of the profile's the faster the body walks forward; user rows as they are."""
    for i in range(base.shape[0]):
        for k in range(base.shape[1]):
            out[i, k] = base[i, k]
        if is_user[i]:
            continue
        mid = 0.0
        if stepping[i] and s[i] >= DS:
            mid = math.sin(math.pi * min(max((s[i] - DS) / (1.0 - DS), 0.0), 1.0))
        fwd = vel[i, 0] * math.cos(heading[i]) + vel[i, 1] * math.sin(heading[i])
        frac = min(max(fwd / max(pref_speed[i], 1e-6), 0.0), 1.0)
        out[i, LIMIT_TURN_WALKING] = base[i, LIMIT_TURN_WALKING] * (1.0 - 0.2 * mid)
        out[i, LIMIT_BACKWARD] = base[i, LIMIT_BACKWARD] * (1.0 - 0.6 * frac)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def foot_pose(ref_x, ref_y, yaw, pitch, lift, heel_z, ball_z, ball_h, ankle_h):  # type: ignore[no-untyped-def]
    """Ankle position (3D, Y up) of a foot given reference, yaw, pitch and lift.

    ψ > 0 rotates about the ball joint (heel up), ψ < 0 about the heel
    contact (toes up). Returns ``(x, y, z)`` of the ankle.
    """
    return foot_pose_cs(ref_x, ref_y, math.cos(yaw), math.sin(yaw), pitch >= 0.0, math.cos(pitch),
                        math.sin(pitch), lift, heel_z, ball_z, ball_h, ankle_h)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def foot_pose_cs(ref_x, ref_y, cy, sy, heel_up, c, s, lift, heel_z, ball_z, ball_h, ankle_h):  # type: ignore[no-untyped-def]
    """:func:`foot_pose` from the cosine and sine of the yaw (``cy, sy``) and of the pitch (``c, s``)."""
    if heel_up:
        pf, pu = ball_z, ball_h  # pivot in the foot's sagittal frame (fwd, up)
    else:
        pf, pu = heel_z, 0.0
    rf, ru = -pf, ankle_h - pu  # ankle relative to the pivot
    af = pf + rf * c + ru * s
    au = pu - rf * s + ru * c + lift
    return ref_x + af * cy, au, ref_y + af * sy
