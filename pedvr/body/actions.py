"""Subconscious actions and the body-resource manager (Ashida et al. 2001, §3–4).

Actions (:data:`ACTIONS`) arrive as Poisson events whose per-second rates
(:data:`BASE_RATE`) are modulated by the agent model (:func:`modulated_rates`):
tiredness grows with time awake (yawning), boredom grows while standing and
fades while walking (:func:`boredom_step`; touching and scratching), fear
raises looking around and lowers scratching, a speaking role raises gestures,
sad agents look down more. Durations are Gamma-distributed with mean
:data:`MEAN_DURATION`. Handedness orders an action's alternative resource
sets (a right-handed agent scratches with the right hand when it is free,
else with the left).

Calibration (where each constant comes from)
--------------------------------------------
Ashida et al. §3.2 counted these actions on 33 pedestrians filmed for 35 s
each on a university sidewalk, averaged the counts into "an average person",
and turned them into a distribution over time with a mean action duration of
3 s. The paper publishes the design (the action list, 33 × 35 s, 3 s), not
the counts. :data:`CLIP_COUNTS` is our reading of such an average 35-s clip
of a walker: looking around and looking down are the common ones, a touch of
face or body about one walker in five, a scratch one in ten, a yawn one in
twenty, gestures mostly from walkers in company. That is 1.85 actions per
35 s (one about every 19 s) and a walker touching or scratching 5 % of the
time. ``BASE_RATE = CLIP_COUNTS / 35 s``.

The agent-model factors are the paper's qualitative statements (§3.3) made
numbers ("the ways in which the Agent Model parameters alter the
subconscious action distribution are empirically derived"): boredom doubles
touching and scratching at its fullest (``BOREDOM_GAIN``); it rises toward 1
with a 5-minute time constant while the body stands (waiting becomes
boring over minutes, not seconds) and falls with a 1-minute one while it
walks (``BOREDOM_RISE``, ``BOREDOM_FALL``), so a neutral agent standing for a
long time touches or scratches about 10 % of the time, not the 53 % of a
boredom that saturated within a minute at 4× the rate. Fear: "a fearful
character is less likely to perform behaviors such as scratching" (§1, citing
Gallaher 1992) — scratching × ``1 − FEAR_CALM·fear``, touching half as much
— and "fear increases the frequency of looking around" (× ``1 + 4·fear``).

Resources are bits: ``HEAD``, ``LEFT_ARM``, ``RIGHT_ARM``, ``UPPER_TORSO``
(the legs are reserved for walking). Each agent has one queue of
``QUEUE`` slots holding planned (from body capabilities, always preferred)
and subconscious entries; an entry launches when one of its alternative
resource sets is wholly free; a subconscious entry's urgency grows while it
waits (an unscratched itch) and it is forgotten after ``GIVE_UP`` s.
Resources held by a running action are never given to another: the
scheduler is the only writer of ``running``.

Everything per agent runs in :func:`schedule_kernel`; random numbers are
drawn in Python from the body's generator, in a fixed order, and passed in.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

ACTIONS = ("head_touch", "body_touch", "head_scratch", "body_scratch", "yawn", "look_around",
           "look_down", "gesture_talk", "gesture_shrug")
N_ACTIONS = len(ACTIONS)
(A_HEAD_TOUCH, A_BODY_TOUCH, A_HEAD_SCRATCH, A_BODY_SCRATCH, A_YAWN, A_LOOK_AROUND, A_LOOK_DOWN,
 A_TALK, A_SHRUG) = range(N_ACTIONS)
HEAD, LEFT_ARM, RIGHT_ARM, UPPER_TORSO = 1, 2, 4, 8
RESOURCES = (("Head", HEAD), ("LeftArm", LEFT_ARM), ("RightArm", RIGHT_ARM), ("UpperTorso", UPPER_TORSO))
N_RES = 4

# Alternative resource sets: (right-handed choice, left-handed choice).
ALTERNATIVES = np.array([
    [RIGHT_ARM | HEAD, LEFT_ARM | HEAD],
    [RIGHT_ARM, LEFT_ARM],
    [RIGHT_ARM | HEAD, LEFT_ARM | HEAD],
    [RIGHT_ARM | UPPER_TORSO, LEFT_ARM | UPPER_TORSO],
    [RIGHT_ARM | HEAD | UPPER_TORSO, LEFT_ARM | HEAD | UPPER_TORSO],
    [HEAD, HEAD],
    [HEAD, HEAD],
    [LEFT_ARM | RIGHT_ARM, LEFT_ARM | RIGHT_ARM],
    [LEFT_ARM | RIGHT_ARM | UPPER_TORSO | HEAD, LEFT_ARM | RIGHT_ARM | UPPER_TORSO | HEAD],
], np.int64)
CLIP_SECONDS = 35.0  # Ashida §3.2: each of the 33 subjects was filmed for 35 s
CLIP_COUNTS = np.array([0.2, 0.2, 0.1, 0.1, 0.05, 0.6, 0.4, 0.15, 0.05])
"""Occurrences of each action in an average 35-s clip of a neutral, rested, unafraid walker (see above)."""
BASE_RATE = CLIP_COUNTS / CLIP_SECONDS
"""Events per second of each action for a neutral, rested, unafraid, non-speaking agent."""
MEAN_DURATION = 3.0  # s: Ashida §3.2's average action duration
RESTLESS = np.array([A_HEAD_TOUCH, A_BODY_TOUCH, A_HEAD_SCRATCH, A_BODY_SCRATCH])
BOREDOM_GAIN = 1.0  # touching and scratching × (1 + BOREDOM_GAIN · boredom)
BOREDOM_RISE = 300.0  # s: time constant of boredom rising toward 1 while standing
BOREDOM_FALL = 60.0  # s: time constant of boredom falling toward 0 while walking
FEAR_CALM = 0.7  # scratching × (1 − FEAR_CALM · fear); touching × (1 − FEAR_CALM · fear / 2)
QUEUE = 6
GIVE_UP = 8.0  # s: a subconscious entry still waiting after this is forgotten
URGENCY_GROWTH = 0.25  # priority per second of waiting
PLANNED_PRIORITY = 100.0
EMPTY = -1


@njit(cache=True, fastmath=True, inline="always")
def _bored(boredom, standing, dt):  # type: ignore[no-untyped-def]
    if standing:
        return boredom + (1.0 - boredom) * (1.0 - math.exp(-dt / BOREDOM_RISE))
    return boredom * math.exp(-dt / BOREDOM_FALL)


@njit(cache=True, fastmath=True)
def _boredom_kernel(boredom, standing, dt, out):  # type: ignore[no-untyped-def]
    for i in range(boredom.shape[0]):
        out[i] = _bored(boredom[i], standing[i], dt)


def boredom_step(boredom: np.ndarray, standing: np.ndarray, dt: float) -> np.ndarray:
    """Boredom after ``dt`` s: toward 1 with ``BOREDOM_RISE`` while standing, toward 0 with
    ``BOREDOM_FALL`` while walking (exact exponential steps, so the tick length does not matter)."""
    b = np.asarray(boredom, np.float64)
    out = np.empty_like(b)
    _boredom_kernel(b, np.broadcast_to(np.asarray(standing, np.bool_), b.shape).copy(), float(dt), out)
    return out


@njit(cache=True, fastmath=True, inline="always")
def arrival_probability(rate, dt):  # type: ignore[no-untyped-def]
    """Probability that a Poisson event of ``rate`` per second arrives within ``dt``."""
    return 1.0 - math.exp(-rate * dt)


@njit(cache=True, fastmath=True, inline="always")
def rates_row(i, tiredness, boredom, fear, speaking, emotion, base, out):  # type: ignore[no-untyped-def]
    """Body ``i``'s per-second rates ``out (A,)`` (see :func:`modulated_rates`)."""
    for a in range(base.shape[0]):
        out[a] = base[a]
    out[A_YAWN] *= 1.0 + 4.0 * tiredness
    restless = 1.0 + BOREDOM_GAIN * boredom
    calm = FEAR_CALM * fear
    out[A_HEAD_SCRATCH] *= restless * (1.0 - calm)
    out[A_BODY_SCRATCH] *= restless * (1.0 - calm)
    out[A_HEAD_TOUCH] *= restless * (1.0 - 0.5 * calm) * (1.0 + 1.5 * emotion[i, 4])
    out[A_BODY_TOUCH] *= restless * (1.0 - 0.5 * calm)
    out[A_LOOK_AROUND] *= 1.0 + 4.0 * fear + 1.5 * emotion[i, 4]  # worried
    out[A_LOOK_DOWN] *= 1.0 + 2.0 * emotion[i, 2] + 1.0 * emotion[i, 5]  # sad, tired
    if speaking:
        out[A_TALK] *= 5.0
        out[A_SHRUG] *= 5.0


@njit(cache=True, fastmath=True)
def rates_kernel(tiredness, boredom, fear, speaking, emotion, base, out):  # type: ignore[no-untyped-def]
    for i in range(out.shape[0]):
        rates_row(i, tiredness[i], boredom[i], fear[i], speaking[i], emotion, base, out[i])


def modulated_rates(*, tiredness: np.ndarray, boredom: np.ndarray, fear: np.ndarray,
                    speaking: np.ndarray, emotion: np.ndarray) -> np.ndarray:
    """Per-agent rates ``(N, A)`` per second from the agent model (all ``(N,)`` in [0, 1]); see the module
    docstring for each factor's source."""
    out = np.empty((tiredness.shape[0], N_ACTIONS))
    f64 = np.float64
    rates_kernel(np.asarray(tiredness, f64), np.asarray(boredom, f64), np.asarray(fear, f64),
                 np.asarray(speaking, np.bool_), np.asarray(emotion, f64), BASE_RATE, out)
    return out


@njit(cache=True, fastmath=True)
def arrivals(rates, u, dt, out):  # type: ignore[no-untyped-def]
    """``out (N,A)``: which Poisson events of ``rates (N,A)`` per second arrive within ``dt``, from
    uniforms ``u (N,A)``."""
    for i in range(rates.shape[0]):
        for a in range(rates.shape[1]):
            out[i, a] = u[i, a] < arrival_probability(rates[i, a], dt)


@njit(cache=True, fastmath=True)
def agent_model_kernel(t, dt, tiredness0, boredom, fear, speaking, emotion, standing, measured, u,
                       arrive):  # type: ignore[no-untyped-def]
    """One decision tick of the agent model for every body: boredom (:func:`boredom_step`), tiredness
    (``tiredness0 + t / 1 h``), the rates, and which subconscious actions arrive (``u (N,A)`` uniforms,
    ``arrive (N,A)`` written). Only ``measured`` rows (virtual agents) act. Returns nothing."""
    r = np.empty(arrive.shape[1])
    for i in range(arrive.shape[0]):
        boredom[i] = _bored(boredom[i], standing[i], dt)
        tired = min(max(tiredness0[i] + t / 3600.0, 0.0), 1.0)
        rates_row(i, tired, boredom[i], fear[i], speaking[i], emotion, BASE_RATE, r)
        for a in range(arrive.shape[1]):
            arrive[i, a] = measured[i] and u[i, a] < arrival_probability(r[a], dt)


@njit(cache=True)
def schedule_kernel(t, dt, arrive, durations, right_handed, blocked, q_kind, q_prio, q_wait,
                    q_planned, q_dur, run_kind, run_end, run_mask, alts, itch, started):  # type: ignore[no-untyped-def]
    """One scheduling tick for every agent.

    ``arrive (N,A)`` the subconscious actions arriving now (:func:`arrivals`,
    :func:`agent_model_kernel`); ``durations (N,A)`` their drawn durations
    (read where ``arrive``); ``blocked (N,)``
    resource bits held by something outside the scheduler (the gaze rule
    holds the head). Queue ``(N,Q)`` arrays; running ``run_kind (N,R)``
    action per resource slot (-1 free), ``run_end (N,R)``, ``run_mask
    (N,R)`` the resource set of the action in that slot; ``itch (N,A)``
    accumulated urgency. ``started (N,R)`` is written: True where a slot
    launched an action at this tick. Returns nothing; arrays are updated in place.
    """
    n = arrive.shape[0]
    na = arrive.shape[1]
    nq = q_kind.shape[1]
    nr = run_kind.shape[1]
    for i in range(n):
        # 1. finished actions free their resources
        for r in range(nr):
            started[i, r] = False
            if run_kind[i, r] >= 0 and t >= run_end[i, r]:
                run_kind[i, r] = -1
                run_mask[i, r] = 0
        # 2. arrivals (subconscious), one per action kind at most
        for a in range(na):
            if arrive[i, a]:
                present = False
                for k in range(nq):
                    if q_kind[i, k] == a:
                        present = True
                if present:
                    continue
                for k in range(nq):
                    if q_kind[i, k] < 0:
                        q_kind[i, k] = a
                        q_prio[i, k] = 1.0 + itch[i, a]
                        q_wait[i, k] = 0.0
                        q_planned[i, k] = False
                        q_dur[i, k] = durations[i, a]
                        break
        # 3. urgency grows while waiting; old subconscious entries are forgotten
        for k in range(nq):
            if q_kind[i, k] < 0:
                continue
            q_wait[i, k] += dt
            if not q_planned[i, k]:
                q_prio[i, k] += URGENCY_GROWTH * dt
                itch[i, q_kind[i, k]] += URGENCY_GROWTH * dt
                if q_wait[i, k] > GIVE_UP:
                    q_kind[i, k] = -1
        # 4. launch by priority while resources allow
        busy = blocked[i]
        for r in range(nr):
            busy |= run_mask[i, r]
        while True:
            best = -1
            best_p = -1e300
            best_set = 0
            for k in range(nq):
                a = q_kind[i, k]
                if a < 0:
                    continue
                first = 0 if right_handed[i] else 1
                chosen = 0
                for m in range(2):
                    sset = alts[a, (first + m) % 2]
                    if (sset & busy) == 0:
                        chosen = sset
                        break
                if chosen == 0:
                    continue
                p = q_prio[i, k] + (PLANNED_PRIORITY if q_planned[i, k] else 0.0)
                if p > best_p:
                    best_p = p
                    best = k
                    best_set = chosen
            if best < 0:
                break
            slot = -1
            for r in range(nr):
                if run_kind[i, r] < 0:
                    slot = r
                    break
            if slot < 0:
                break
            a = q_kind[i, best]
            run_kind[i, slot] = a
            started[i, slot] = True
            run_end[i, slot] = t + q_dur[i, best]
            run_mask[i, slot] = best_set
            busy |= best_set
            itch[i, a] = 0.0
            q_kind[i, best] = -1
