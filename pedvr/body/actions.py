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


def boredom_step(boredom: np.ndarray, standing: np.ndarray, dt: float) -> np.ndarray:
    """Boredom after ``dt`` s: toward 1 with ``BOREDOM_RISE`` while standing, toward 0 with
    ``BOREDOM_FALL`` while walking (exact exponential steps, so the tick length does not matter)."""
    rise = 1.0 - np.exp(-dt / BOREDOM_RISE)
    fall = np.exp(-dt / BOREDOM_FALL)
    return np.where(standing, boredom + (1.0 - boredom) * rise, boredom * fall)


def modulated_rates(*, tiredness: np.ndarray, boredom: np.ndarray, fear: np.ndarray,
                    speaking: np.ndarray, emotion: np.ndarray) -> np.ndarray:
    """Per-agent rates ``(N, A)`` per second from the agent model (all ``(N,)`` in [0, 1]); see the module
    docstring for each factor's source."""
    r = np.tile(BASE_RATE, (tiredness.shape[0], 1))
    r[:, A_YAWN] *= 1.0 + 4.0 * tiredness
    r[:, RESTLESS] *= (1.0 + BOREDOM_GAIN * boredom)[:, None]
    for a in (A_HEAD_SCRATCH, A_BODY_SCRATCH):
        r[:, a] *= 1.0 - FEAR_CALM * fear
    for a in (A_HEAD_TOUCH, A_BODY_TOUCH):
        r[:, a] *= 1.0 - 0.5 * FEAR_CALM * fear
    r[:, A_LOOK_AROUND] *= 1.0 + 4.0 * fear + 1.5 * emotion[:, 4]  # worried
    r[:, A_LOOK_DOWN] *= 1.0 + 2.0 * emotion[:, 2] + 1.0 * emotion[:, 5]  # sad, tired
    for a in (A_TALK, A_SHRUG):
        r[:, a] *= np.where(speaking, 5.0, 1.0)
    r[:, A_HEAD_TOUCH] *= 1.0 + 1.5 * emotion[:, 4]
    return r


@njit(cache=True)
def schedule_kernel(t, dt, rates, u_arrive, durations, right_handed, blocked, q_kind, q_prio, q_wait,
                    q_planned, q_dur, run_kind, run_end, run_mask, alts, itch):  # type: ignore[no-untyped-def]
    """One scheduling tick for every agent.

    ``rates (N,A)`` per second; ``u_arrive (N,A)`` uniforms; ``durations
    (N,A)`` drawn durations for entries arriving now; ``blocked (N,)``
    resource bits held by something outside the scheduler (the gaze rule
    holds the head). Queue ``(N,Q)`` arrays; running ``run_kind (N,R)``
    action per resource slot (-1 free), ``run_end (N,R)``, ``run_mask
    (N,R)`` the resource set of the action in that slot; ``itch (N,A)``
    accumulated urgency. Returns nothing; arrays are updated in place.
    """
    n = rates.shape[0]
    na = rates.shape[1]
    nq = q_kind.shape[1]
    nr = run_kind.shape[1]
    for i in range(n):
        # 1. finished actions free their resources
        for r in range(nr):
            if run_kind[i, r] >= 0 and t >= run_end[i, r]:
                run_kind[i, r] = -1
                run_mask[i, r] = 0
        # 2. arrivals (subconscious), one per action kind at most
        for a in range(na):
            if u_arrive[i, a] < 1.0 - math.exp(-rates[i, a] * dt):
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
            run_end[i, slot] = t + q_dur[i, best]
            run_mask[i, slot] = best_set
            busy |= best_set
            itch[i, a] = 0.0
            q_kind[i, best] = -1
