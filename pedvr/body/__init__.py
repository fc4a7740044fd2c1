"""Bodies: skeleton, FK, footstep locomotion, upper-body style, gaze, gestures, coordinator.

The simulation owns one :class:`FullBody` (``sim.body``); its rows align
with ``sim.crowd`` rows (the user is a row too: hidden in first person, but
posed from its input so a third-person or overhead view can draw it).

Renderer-facing pose API (read-only; valid after each ``Simulation.step``)
--------------------------------------------------------------------------
* ``JOINTS`` (26 names), ``END_SITES`` (7 names), ``NODES = JOINTS + END_SITES``,
  ``PARENTS (33,) int64`` (-1 for the pelvis; parents precede children).
* ``sim.body.joint_matrices(out=None) -> (N, 26, 4, 4) float32``: world
  transforms of the joints, column-vector convention (``p_world = M @ [p, 1]``),
  3D Y up, metres. For skinning, the bind pose is the rest pose (every local
  rotation identity, arms hanging); its joint world positions are
  ``rest_positions(dims)`` and its rotations identity, so a skinning matrix is
  ``M_joint @ inverse(bind_translation)``.
* ``sim.body.state.world_pos (N, 33, 3) float64`` and ``world_q (N, 33, 4)``
  (``x, y, z, w``) for every node, end sites included (head top, heels, toe
  tips, hand tips); ``state.local_q (N, 26, 4)`` local rotations,
  ``state.pelvis (N, 3)`` pelvis translation in the root frame.
* ``sim.body.state.dims (N, 4)``: height m, sex (0 male, 1 female), build
  [0, 1], scale (= height / 1.75); ``state.offsets (N, 33, 3)`` per-agent rest
  offsets; ``sim.body.ids (N,)`` the agents' stable ids (= ``crowd.ids``).
* Eyes: joints ``LEye``/``REye`` look along their local +Z.

Conventions: local frames +Y up, +Z forward, +X the character's left; a 2D
ground point (x, y) is 3D (x, 0, y); a 2D heading θ is a rotation about +Y
by π/2 − θ (so a CCW turn in 2D is a negative turn about +Y in 3D, and the
character's left lies along 2D θ − π/2). See :mod:`pedvr.body.quat`.

Behavior-facing API
-------------------
``go_to``, ``gaze_at``, ``reach_for``, ``gesture``, ``sit_down``,
``stand_up`` on :class:`FullBody` return a :class:`Handle` whose ``status``
is ``Status.RUNNING / SUCCESS / FAILURE``; a ``None`` target stops; a bad
call (unknown gesture, malformed target) raises ``UsageError`` and changes
nothing.

Simulation-facing input: ``sim.body.state.shoulder_turn (N,)`` rad, the
upper torso's yaw relative to the pelvis (0 by default), read at each step.
"""

from __future__ import annotations

import numpy as np

from pedvr.body.model import BodyState, FullBody, GestureSets, Handle, Status
from pedvr.body.skeleton import END_SITES, JOINTS, NODES, PARENTS, REST_OFFSETS, dims_offsets


def rest_positions(dims: np.ndarray) -> np.ndarray:
    """Bind-pose node positions ``(N, 33, 3)`` in the body frame for dims ``(N, 4)``."""
    off = dims_offsets(np.asarray(dims, np.float64).reshape(-1, 4))
    out = np.zeros_like(off)
    for k, p in enumerate(PARENTS):
        out[:, k] = off[:, k] + (out[:, p] if p >= 0 else 0.0)
    return out


__all__ = ["BodyState", "END_SITES", "FullBody", "GestureSets", "Handle", "JOINTS", "NODES", "PARENTS",
           "REST_OFFSETS", "Status", "rest_positions"]
