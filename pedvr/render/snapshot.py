"""What a frame shows: a read-only copy of the simulation state the renderer needs (no GL).

The renderer reads simulation state and never writes it (DESIGN.md); a
:class:`Snapshot` is taken after ``sim.advance_to(t)`` and drawn, so drawing
never sees a half-updated world.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pedvr.sim import Simulation

SPHERE_HEIGHT = 1.25  # m: the red route target floats at chest height, below the eyes (issue 16)
TARGET_RADIUS = 0.11  # m: its drawn size (the scene's sphere_radius is how near counts as reached)


@dataclass(frozen=True)
class Snapshot:
    """Per-agent arrays (rows as in the crowd; the user row, if any, flagged in ``is_user``).

    ``bones`` ``(N, 26, 4, 4) float32`` are the body layer's joint world
    matrices (``sim.body.joint_matrices()``) and ``dims`` ``(N, 4)`` its body
    dimensions (height, sex, build, scale); a snapshot without them (made by
    hand) is drawn with everyone standing (:func:`~pedvr.render.figures.standing_bones`).
    ``gaze_target`` is ``(N, 3)`` world points for the overhead view's gaze
    lines (NaN rows: none); the figures' eyes follow ``bones``, not this.
    ``sphere`` is the next red target sphere on the ground, or None when the
    route is done; ``route`` all spheres. ``doors`` ``(L, 5)`` is every door
    leaf's hinge x, hinge y, world angle, length and height
    (``DoorLeaves.pose()``); None draws them closed. ``character`` ``(N,)``
    indexes the renderer's characters per agent (None: chosen by ``profile``,
    each agent's index into the scene's profiles, -1 for the user, through
    the scene's ``characters`` keys; neither: the procedural character).
    ``carrying`` ``(N,) int8`` is what each agent carries (:mod:`pedvr.body.carry`: 0 nothing,
    1 a box, 2 a perambulator), drawn at ``carry_frame`` ``(N, 5)`` (the body's: a box's centre
    between the hands, a pram's root, the yaw and a box's tilt in the hands,
    :func:`pedvr.body.carry.object_frame`; None:
    at ``pos`` facing ``heading`` as a body holds it standing), :mod:`pedvr.render.carried`;
    None: nothing.
    """

    t: float
    ids: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    heading: np.ndarray
    radius: np.ndarray
    is_user: np.ndarray
    gaze_target: np.ndarray | None = None
    bones: np.ndarray | None = None
    dims: np.ndarray | None = None
    sphere: np.ndarray | None = None
    sphere_radius: float = 0.5
    route: np.ndarray | None = None
    next_sphere: int = 0
    doors: np.ndarray | None = None
    character: np.ndarray | None = None
    profile: np.ndarray | None = None
    carrying: np.ndarray | None = None
    carry_frame: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @property
    def user_row(self) -> int | None:
        rows = np.flatnonzero(self.is_user)
        return int(rows[0]) if rows.size else None

    @classmethod
    def from_sim(cls, sim: Simulation, *, gaze_target: np.ndarray | None = None) -> Snapshot:
        c = sim.crowd
        sphere = None
        route = None
        nxt = 0
        radius = sim.scene.user.sphere_radius
        if sim.user is not None:
            route = sim.user.route.copy()
            nxt = sim.user.sphere
            if not sim.user.route_done:
                sphere = sim.user.route[sim.user.sphere].copy()
        return cls(
            t=sim.t,
            ids=c.ids.copy(),
            pos=c.pos.copy(),
            vel=c.vel.copy(),
            heading=c.heading.copy(),
            radius=c.radius.copy(),
            is_user=c.is_user.copy(),
            gaze_target=(sim.body.gaze_targets(c) if gaze_target is None
                         else np.asarray(gaze_target, dtype=np.float64)),
            bones=sim.body.joint_matrices(),
            dims=sim.body.state.dims.copy(),
            sphere=sphere,
            sphere_radius=radius,
            route=route,
            next_sphere=nxt,
            doors=sim.doors.pose() if len(sim.doors) else None,
            profile=sim.profile_index.copy(),
            carrying=sim.body.state.carrying.copy(),
            carry_frame=sim.body.state.carry_frame.copy(),
        )

    @classmethod
    def of_agents(
        cls,
        *,
        pos: np.ndarray,
        heading: np.ndarray,
        vel: np.ndarray | None = None,
        ids: np.ndarray | None = None,
        radius: float = 0.25,
        is_user: np.ndarray | None = None,
        gaze_target: np.ndarray | None = None,
        bones: np.ndarray | None = None,
        dims: np.ndarray | None = None,
        sphere: np.ndarray | None = None,
        doors: np.ndarray | None = None,
        character: np.ndarray | None = None,
        t: float = 0.0,
    ) -> Snapshot:
        """A hand-made snapshot (tests, benchmarks): agents at ``pos`` facing ``heading``.

        Pass ``bones`` and ``dims`` of a :class:`~pedvr.body.FullBody` to draw its poses.
        """
        pos = np.asarray(pos, dtype=np.float64).reshape(-1, 2)
        n = pos.shape[0]
        return cls(
            t=t,
            ids=np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids, dtype=np.int64),
            pos=pos,
            vel=np.zeros((n, 2)) if vel is None else np.asarray(vel, dtype=np.float64).reshape(n, 2),
            heading=np.asarray(heading, dtype=np.float64).reshape(n),
            radius=np.full(n, radius),
            is_user=np.zeros(n, np.bool_) if is_user is None else np.asarray(is_user, np.bool_),
            gaze_target=gaze_target,
            bones=bones,
            dims=dims,
            sphere=None if sphere is None else np.asarray(sphere, np.float64),
            doors=None if doors is None else np.asarray(doors, np.float64),
            character=None if character is None else np.asarray(character, np.int64),
        )
