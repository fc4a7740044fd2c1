"""The overhead debug view's geometry (pure numpy): the paper's Fig. 1 right and Fig. 4 as 2D drawing.

Obstacles filled, the bounds outlined, door leaves as lines, every agent a disc with a heading tick
and a velocity line (and the outline of a box or pram it carries, :mod:`pedvr.render.carried`),
the user's disc in blue, gaze lines from each gazing agent to what it looks at, the red-sphere
route with the next sphere filled.
Coordinates are ground ``(x, y)``; the view looks down from above the 3D
world, so 2D ``+y`` points down the screen (:func:`pedvr.render.math3d.overhead_transform`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pedvr.render.carried import frames, outline_segments
from pedvr.render.environment import _cap_triangles, kind_colour
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import WorldConfig

LINE_DTYPE = np.dtype([("pos", "<f4", 2), ("color", "<f4", 4)])
DISC_DTYPE = np.dtype([("disc", "<f4", 3), ("color", "<f4", 4)])

BACKGROUND = (0.96, 0.96, 0.94)
AGENT = (0.55, 0.55, 0.58, 1.0)
USER = (0.10, 0.35, 0.95, 1.0)
VELOCITY = (0.10, 0.10, 0.10, 1.0)
HEADING = (1.0, 1.0, 1.0, 1.0)
GAZE = (0.05, 0.65, 0.15, 1.0)
SPHERE = (0.90, 0.08, 0.06, 1.0)
ROUTE = (0.90, 0.45, 0.40, 1.0)
BOUNDS = (0.2, 0.2, 0.2, 1.0)
DOOR = (0.50, 0.30, 0.12, 1.0)
CARRIED = {1: (0.62, 0.42, 0.18, 1.0), 2: (0.16, 0.24, 0.42, 1.0)}  # box, perambulator outlines


@dataclass(frozen=True)
class OverheadGeometry:
    """Triangles (static), lines and discs (per frame), ready for the GL buffers."""

    triangles: np.ndarray
    lines: np.ndarray
    discs: np.ndarray


def static_triangles(world: WorldConfig) -> np.ndarray:
    """Filled obstacles, coloured by kind (sRGB-ish: this view is a plot, not lit)."""
    parts = []
    for ob in world.obstacles:
        tris = _cap_triangles(np.asarray(ob.vertices, dtype=np.float64)).reshape(-1, 2)
        v = np.zeros(len(tris), dtype=LINE_DTYPE)
        v["pos"] = tris
        v["color"] = np.append(kind_colour(ob.kind) ** (1 / 2.2) * 0.8, 1.0)
        parts.append(v)
    return np.concatenate(parts) if parts else np.zeros(0, dtype=LINE_DTYPE)


def _segments(a: np.ndarray, b: np.ndarray, colour: tuple[float, ...]) -> np.ndarray:
    v = np.zeros(2 * len(a), dtype=LINE_DTYPE)
    v["pos"][0::2], v["pos"][1::2] = a, b
    v["color"] = colour
    return v


def frame_geometry(
    world: WorldConfig, snap: Snapshot, *, velocity_scale: float = 1.0, disc_sides: int = 24
) -> tuple[np.ndarray, np.ndarray]:
    """Lines and discs of one frame (the triangles are static: :func:`static_triangles`)."""
    (x0, y0), (x1, y1) = world.bounds
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    lines = [_segments(corners, np.roll(corners, -1, axis=0), BOUNDS)]
    if snap.doors is not None and len(snap.doors):
        leaf = np.asarray(snap.doors, np.float64)
        hinge = leaf[:, :2]
        tip = hinge + leaf[:, 3:4] * np.stack([np.cos(leaf[:, 2]), np.sin(leaf[:, 2])], axis=1)
        lines.append(_segments(hinge, tip, DOOR))
    discs = []
    if snap.route is not None and len(snap.route):
        r = snap.route
        lines.append(_segments(r[:-1], r[1:], ROUTE))
        ang = np.linspace(0, 2 * np.pi, disc_sides + 1)
        for k, p in enumerate(r):
            ring = p + snap.sphere_radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)
            lines.append(_segments(ring[:-1], ring[1:], SPHERE if k >= snap.next_sphere else ROUTE))
    if snap.sphere is not None:
        d = np.zeros(1, dtype=DISC_DTYPE)
        d["disc"] = (snap.sphere[0], snap.sphere[1], snap.sphere_radius * 0.5)
        d["color"] = SPHERE
        discs.append(d)
    n = len(snap)
    if n:
        d = np.zeros(n, dtype=DISC_DTYPE)
        d["disc"][:, :2], d["disc"][:, 2] = snap.pos, snap.radius
        d["color"] = np.where(snap.is_user[:, None], USER, AGENT)
        discs.append(d)
        fwd = np.stack([np.cos(snap.heading), np.sin(snap.heading)], axis=1)
        lines.append(_segments(snap.pos, snap.pos + fwd * snap.radius[:, None], HEADING))
        lines.append(_segments(snap.pos, snap.pos + snap.vel * velocity_scale, VELOCITY))
        if snap.carrying is not None and np.any(snap.carrying):
            scale = np.ones(n) if snap.dims is None else np.asarray(snap.dims, np.float64)[:, 3]
            frame = frames(snap.carrying, snap.carry_frame, snap.pos, snap.heading, scale)
            ends, kinds = outline_segments(snap.carrying, frame, scale)
            seg = _segments(ends[0::2], ends[1::2], (0.0, 0.0, 0.0, 1.0))
            seg["color"] = np.asarray([CARRIED[int(k)] for k in kinds], np.float32).repeat(2, axis=0)
            lines.append(seg)
        if snap.gaze_target is not None:
            g = np.asarray(snap.gaze_target, dtype=np.float64)
            has = np.all(np.isfinite(g), axis=1)
            if has.any():
                lines.append(_segments(snap.pos[has], g[has][:, [0, 2]], GAZE))
    return np.concatenate(lines), np.concatenate(discs) if discs else np.zeros(0, dtype=DISC_DTYPE)


def disc_fan(sides: int = 24) -> np.ndarray:
    """Unit-circle triangle list (centre, rim k, rim k+1) for instanced discs."""
    ang = np.linspace(0, 2 * np.pi, sides + 1)
    rim = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    tris = np.zeros((sides, 3, 2))
    tris[:, 1], tris[:, 2] = rim[:-1], rim[1:]
    return tris.reshape(-1, 2).astype(np.float32)
