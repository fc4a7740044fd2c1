"""ADAPT's coordinator: choreographers, the pose dataflow graph, weights and messages (ADAPT §4).

A :class:`Choreographer` declares what it is (a *generator* poses a shadow
from nothing, a *transformer* takes the pose flowing through the graph) and
which joints it affects (its mask, and whether it moves the pelvis). The
:class:`Coordinator` chains them with two-input blend nodes: the pose starts
at the rest pose and each choreographer's shadow is blended in, on its
masked joints, with its per-agent weight. Later nodes win (ADAPT §4.3).

The default order is ADAPT §4.5's: ascending specificity ``S = depth /
coverage`` (depth: the most joints between an affected joint and the
pelvis; coverage: the number of affected joints), so broad choreographers
(locomotion) come first and narrow ones (reach) last; ties keep
registration order. Pass ``order=`` to override.

Weights move linearly toward their targets, reaching them in ``smoothing``
seconds (0.5 s: ADAPT smooths weight changes over several frames).
Messages are named per-agent flags any choreographer may post and read
(e.g. locomotion posts ``running``; gaze restricts the torso when it
reads it) without knowing who posted them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from pedvr.body import pose as ps
from pedvr.body import skeleton as sk
from pedvr.errors import UsageError

MESSAGES = ("running", "walking", "sitting", "gesturing", "reaching")


@dataclass(frozen=True)
class Choreographer:
    name: str
    kind: str  # "generator" | "transformer"
    mask: np.ndarray  # (J,) bool
    moves_pelvis: bool = False

    @property
    def coverage(self) -> int:
        return int(self.mask.sum())

    @property
    def depth(self) -> int:
        return max(sk.depth_of(int(j)) for j in np.flatnonzero(self.mask))

    @property
    def specificity(self) -> float:
        return self.depth / self.coverage


def _mask(*names: str) -> np.ndarray:
    m = np.zeros(sk.J, np.bool_)
    for n in names:
        m[sk.IDX[n]] = True
    return m


def default_choreographers() -> list[Choreographer]:
    """Locomotion and sitting (whole body), gestures (upper body), idle noise, gaze, reach."""
    everything = np.ones(sk.J, np.bool_)
    arms = ("LCollar", "LShoulder", "LElbow", "LWrist", "LHand", "RCollar", "RShoulder", "RElbow",
            "RWrist", "RHand")
    return [
        Choreographer("locomotion", "generator", everything, True),
        Choreographer("sitting", "generator", everything, True),
        Choreographer("gesture", "generator", ps.UPPER_MASK.copy()),
        Choreographer("idle", "transformer", _mask("Pelvis", "Spine2", "Neck", "Head", "LShoulder",
                                                   "RShoulder"), True),
        Choreographer("gaze", "transformer", _mask("Spine1", "Spine2", "Spine3", "Neck", "Head", "LEye",
                                                   "REye")),
        Choreographer("reach", "transformer", _mask(*arms)),
    ]


def order_by_specificity(chs: list[Choreographer]) -> list[str]:
    """ADAPT §4.5: ascending ``depth / coverage``; ties keep the given order."""
    ranked = sorted(enumerate(chs), key=lambda kv: (kv[1].specificity, kv[0]))
    return [c.name for _, c in ranked]


class Coordinator:
    """Blend graph over per-agent weights ``(N, C)`` (C choreographers)."""

    def __init__(self, choreographers: list[Choreographer], *, order: list[str] | None = None,
                 smoothing: float = 0.5) -> None:
        self.choreographers = {c.name: c for c in choreographers}
        self.index = {c.name: k for k, c in enumerate(choreographers)}
        order = order_by_specificity(choreographers) if order is None else list(order)
        unknown = [o for o in order if o not in self.choreographers]
        if unknown or sorted(order) != sorted(self.choreographers):
            raise UsageError(f"coordinator order {order}: must name each of "
                             f"{', '.join(self.choreographers)} once")
        self.order = order
        self.smoothing = float(smoothing)
        c = len(choreographers)
        self.weights = np.zeros((0, c))
        self.targets = np.zeros((0, c))
        self.messages = np.zeros((0, len(MESSAGES)), np.bool_)
        self._base = [self.index[n] for n in ("locomotion", "idle", "gaze") if n in self.index]
        self._graph: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def append(self, n: int) -> None:
        w = np.zeros((n, len(self.index)))
        w[:, self._base] = 1.0  # always on: they return to neutral by themselves
        self.weights = np.concatenate([self.weights, w])
        self.targets = np.concatenate([self.targets, w.copy()])
        self.messages = np.concatenate([self.messages, np.zeros((n, len(MESSAGES)), np.bool_)])

    def keep(self, mask: np.ndarray) -> None:
        self.weights = self.weights[mask]
        self.targets = self.targets[mask]
        self.messages = self.messages[mask]

    def graph(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The graph as :func:`pedvr.body.graph.pose_graph_kernel` runs it: ``order (C, 2)`` rows of
        (node id, weight column) in blending order, ``masks (C, J)``, ``moves_pelvis (C,)``.

        Node ids are :data:`pedvr.body.graph.NODE_NAMES`; a choreographer the kernel has no node
        for cannot be run by it (:class:`UsageError`).
        """
        if self._graph is None:
            from pedvr.body.graph import NODE_NAMES

            unknown = [n for n in self.order if n not in NODE_NAMES]
            if unknown:
                raise UsageError(f"choreographers {unknown}: the pose graph has nodes for "
                                 f"{', '.join(NODE_NAMES)}")
            order = np.array([[NODE_NAMES.index(n), self.index[n]] for n in self.order], np.int64)
            masks = np.stack([self.choreographers[n].mask for n in self.order])
            pelvis = np.array([self.choreographers[n].moves_pelvis for n in self.order])
            self._graph = (order, masks, pelvis)
        return self._graph

    def set_target(self, name: str, value: np.ndarray | float) -> None:
        self.targets[:, self.index[name]] = value

    def smooth(self, dt: float) -> None:
        step = dt / max(self.smoothing, 1e-9)
        d = np.minimum(np.maximum(self.targets - self.weights, -step), step)  # np.clip, without its overhead
        self.weights += d

    def clear_messages(self) -> None:
        self.messages[:] = False

    def post(self, message: str, rows: np.ndarray) -> None:
        self.messages[:, MESSAGES.index(message)] |= rows

    def has(self, message: str) -> np.ndarray:
        return np.ascontiguousarray(self.messages[:, MESSAGES.index(message)])

    def blend(self, name: str, pose_q: np.ndarray, pose_p: np.ndarray, shadow_q: np.ndarray,
              shadow_p: np.ndarray, *, joints: np.ndarray | None = None) -> None:
        """The blend node after choreographer ``name``: in place on ``pose``.

        ``joints (N, J)`` narrows the choreographer's mask per agent (a gesture clip drives only
        its own joints); it needs a choreographer that does not move the pelvis.
        """
        c = self.choreographers[name]
        w = np.ascontiguousarray(self.weights[:, self.index[name]])
        if joints is None:
            ps.blend_kernel(pose_q, pose_p, shadow_q, shadow_p, w, c.mask, c.moves_pelvis)
        else:
            if c.moves_pelvis:
                raise ValueError(f"{name}: per-agent joint masks are only for choreographers that "
                                 "leave the pelvis")
            ps.blend_rows_kernel(pose_q, shadow_q, w, np.ascontiguousarray(joints & c.mask[None, :]))


@njit(cache=True)
def step_weights_kernel(t, dt, smoothing, vel_s, sitting, carrying, g_kind, g_start, g_dur, run_kind,
                        is_arm_action, reach_on, running_speed, walk_speed, cols, msgs, weights, targets,
                        messages, running, kind, idle_w):  # type: ignore[no-untyped-def]
    """The default choreographers' per-step inputs to the pose graph, one pass over the bodies
    (:meth:`pedvr.body.model.FullBody._pose`; numpy's arithmetic in its order, so the same bytes).

    Messages (all cleared first): ``running`` above ``running_speed``, ``walking`` above
    ``walk_speed`` and not running, ``sitting`` (``msgs``: their columns). Targets (``cols``: the
    sitting, gesture and reach weight columns): sitting is the posture; a gesture's envelope (0.4 s
    ramps) while its clip plays and the body carries nothing; reach while an arm is on a point, on
    something carried or in a subconscious arm action (``is_arm_action`` by action kind). Then
    every weight moves toward its target by at most ``dt / smoothing``. Outputs: ``running (N,)``,
    ``kind (N,)`` the clip that plays or fades (0 none), ``idle_w (N,)`` the idle noise's
    strength (full at rest, none from 0.3 m/s or seated)."""
    step = dt / max(smoothing, 1e-9)
    c_sit, c_gesture, c_reach = cols[0], cols[1], cols[2]
    for i in range(weights.shape[0]):
        speed = np.sqrt(vel_s[i, 0] ** 2 + vel_s[i, 1] ** 2)
        run = speed > running_speed
        running[i] = run
        for m in range(messages.shape[1]):
            messages[i, m] = False
        messages[i, msgs[0]] = run
        messages[i, msgs[1]] = (speed > walk_speed) and not run
        messages[i, msgs[2]] = sitting[i]
        targets[i, c_sit] = 1.0 if sitting[i] else 0.0
        held = carrying[i] != 0
        active = g_kind[i] > 0 and t < g_start[i] + g_dur[i] and not held
        env = min(max(min(t - g_start[i], g_start[i] + g_dur[i] - t) / 0.4, 0.0), 1.0)
        targets[i, c_gesture] = env if active else 0.0
        arm = False
        for s in range(run_kind.shape[1]):
            k = run_kind[i, s]
            if k >= 0 and is_arm_action[k]:
                arm = True
        targets[i, c_reach] = 1.0 if (reach_on[i, 0] or reach_on[i, 1] or held or arm) else 0.0
        for c in range(weights.shape[1]):
            weights[i, c] += min(max(targets[i, c] - weights[i, c], -step), step)
        kind[i] = g_kind[i] if (active or weights[i, c_gesture] > 0.0) else 0
        idle_w[i] = min(max(1.0 - speed / 0.3, 0.0), 1.0) * (0.0 if sitting[i] else 1.0)
