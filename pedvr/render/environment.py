"""Static scene geometry from the scene's polygons (pure numpy and shapely, no GL).

The floor, a barrier along the world bounds (the border acts as a wall in
the simulation), and every obstacle extruded from its counter-clockwise
polygon to its height, shaped and coloured by ``kind``: walls and pillars
full height; tables a top slab on a pedestal; counters solid to their height;
booths and shops with a darker glazed band at eye level. Vertices are
``(position, normal, linear RGB colour)`` in world space (ground ``(x, y)``
→ ``(x, 0, y)``, :mod:`pedvr.render.math3d`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from pedvr.scene.config import Door, Obstacle, WorldConfig

ENV_DTYPE = np.dtype([("pos", "<f4", 3), ("normal", "<f4", 3), ("color", "<f4", 3)])
BOUNDARY_HEIGHT = 1.1  # m: a barrier one can see over, so large outdoor scenes do not feel boxed in
FLOOR_MARGIN = 60.0  # m of floor beyond the bounds, so the horizon is not an edge
TABLE_TOP = 0.05  # m, thickness of a table top
GLAZING = (0.35, 2.3)  # m, the glazed band of shop fronts and booths

_COLOURS = {  # sRGB, converted to linear below
    "wall": (0.80, 0.76, 0.68),
    "pillar": (0.62, 0.62, 0.64),
    "box": (0.55, 0.42, 0.30),
    "polygon": (0.58, 0.56, 0.52),
    "table": (0.55, 0.36, 0.22),
    "counter": (0.45, 0.40, 0.50),
    "booth": (0.30, 0.50, 0.70),
    "shop": (0.78, 0.70, 0.55),
    "boundary": (0.55, 0.53, 0.50),
    "door": (0.56, 0.40, 0.26),
    "door_frame": (0.35, 0.33, 0.32),
}
FLOOR_COLOUR = (0.62, 0.61, 0.58)
GLASS = (0.20, 0.28, 0.32)
LEAF_THICKNESS = 0.045  # m
LEAF_GLAZING = (0.95, 1.85)  # m, the glass panel of a door leaf (the paper's doors are transparent)
FRAME = 0.06  # m, jamb post width and depth beyond the leaf


def linear(srgb: tuple[float, float, float]) -> np.ndarray:
    return np.asarray(srgb, dtype=np.float64) ** 2.2


def kind_colour(kind: str) -> np.ndarray:
    """Linear RGB of an obstacle kind (unknown kinds draw as ``polygon``)."""
    return linear(_COLOURS.get(kind, _COLOURS["polygon"]))


@dataclass(frozen=True)
class EnvironmentMesh:
    """Vertices of the floor (drawn with the grid pattern) and of everything else."""

    floor: np.ndarray
    solids: np.ndarray


def _verts(pos: list[np.ndarray], nrm: list[np.ndarray], col: list[np.ndarray]) -> np.ndarray:
    v = np.zeros(len(pos), dtype=ENV_DTYPE)
    if pos:
        v["pos"], v["normal"], v["color"] = np.asarray(pos), np.asarray(nrm), np.asarray(col)
    return v


def _cap_triangles(poly: np.ndarray) -> np.ndarray:
    """Triangles ``(T, 3, 2)`` covering a simple polygon (constrained Delaunay, CCW)."""
    shape = shapely.Polygon(poly)
    if not shape.is_valid:
        shape = shapely.make_valid(shape)
    tris = shapely.constrained_delaunay_triangles(shape)
    out = []
    for t in shapely.get_parts(tris):
        c = np.asarray(t.exterior.coords)[:3]
        area = (c[1, 0] - c[0, 0]) * (c[2, 1] - c[0, 1]) - (c[2, 0] - c[0, 0]) * (c[1, 1] - c[0, 1])
        out.append(c if area > 0 else c[::-1])
    return np.asarray(out).reshape(-1, 3, 2)


def _prism(
    poly: np.ndarray,
    y0: float,
    y1: float,
    colour: np.ndarray,
    *,
    band: tuple[float, float] | None,
    pos: list[np.ndarray],
    nrm: list[np.ndarray],
    col: list[np.ndarray],
    top: bool = True,
    bottom: bool = False,
) -> None:
    """Sides (split at ``band`` into facade / glass / facade) and caps of a vertical prism."""
    poly = np.asarray(poly, dtype=np.float64)
    cuts = [y0, y1]
    if band is not None:
        cuts = sorted({y0, y1, *(min(max(b, y0), y1) for b in band)})
    glass = linear(GLASS)
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        e = b - a
        length = float(np.hypot(*e))
        if length < 1e-9:
            continue
        # Outward normal of a CCW polygon edge in 2D (x, y) is (e_y, -e_x) -> 3D (e_y, 0, -e_x).
        normal = np.array([e[1], 0.0, -e[0]]) / length
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            if hi - lo < 1e-9:
                continue
            c = glass if band is not None and band[0] <= lo and hi <= band[1] else colour
            a0, b0 = np.array([a[0], lo, a[1]]), np.array([b[0], lo, b[1]])
            a1, b1 = np.array([a[0], hi, a[1]]), np.array([b[0], hi, b[1]])
            # Seen from outside, (a0, b0, b1) runs counter-clockwise given the 2D CCW order and Y up
            # mirrored into z: check with the normal and flip if needed.
            tri = [a0, b0, b1, a0, b1, a1]
            if np.dot(np.cross(b0 - a0, b1 - a0), normal) < 0:
                tri = [a0, b1, b0, a0, a1, b1]
            pos += tri
            nrm += [normal] * 6
            col += [c] * 6
    tris = _cap_triangles(poly)
    for y, up in ((y1, True), (y0, False)):
        if (up and not top) or (not up and not bottom):
            continue
        normal = np.array([0.0, 1.0 if up else -1.0, 0.0])
        for t in tris:
            p3 = [np.array([q[0], y, q[1]]) for q in t]
            if np.dot(np.cross(p3[1] - p3[0], p3[2] - p3[0]), normal) < 0:
                p3 = p3[::-1]
            pos += p3
            nrm += [normal] * 3
            col += [colour] * 3


def obstacle_vertices(ob: Obstacle) -> np.ndarray:
    """The extruded geometry of one obstacle, by kind."""
    pos: list[np.ndarray] = []
    nrm: list[np.ndarray] = []
    col: list[np.ndarray] = []
    poly = np.asarray(ob.vertices, dtype=np.float64)
    colour = kind_colour(ob.kind)
    h = ob.height
    if ob.kind == "table":
        _prism(poly, max(h - TABLE_TOP, 0.0), h, colour, band=None, pos=pos, nrm=nrm, col=col, bottom=True)
        c = poly.mean(axis=0)
        r = min(0.06, 0.25 * float(np.min(np.ptp(poly, axis=0))))
        leg = c + np.array([[-r, -r], [r, -r], [r, r], [-r, r]])
        _prism(
            leg, 0.0, max(h - TABLE_TOP, 0.0), colour * 0.6, band=None, pos=pos, nrm=nrm, col=col, top=False
        )
    elif ob.kind in ("shop", "booth") and h > GLAZING[1]:
        _prism(poly, 0.0, h, colour, band=GLAZING, pos=pos, nrm=nrm, col=col)
    else:
        _prism(poly, 0.0, h, colour, band=None, pos=pos, nrm=nrm, col=col)
    return _verts(pos, nrm, col)


def boundary_vertices(
    world: WorldConfig, *, height: float = BOUNDARY_HEIGHT, thickness: float = 0.15
) -> np.ndarray:
    """A barrier just outside the world bounds (four thin prisms)."""
    (x0, y0), (x1, y1) = world.bounds
    t = thickness
    rects = [
        ((x0 - t, y0 - t), (x1 + t, y0)),
        ((x0 - t, y1), (x1 + t, y1 + t)),
        ((x0 - t, y0), (x0, y1)),
        ((x1, y0), (x1 + t, y1)),
    ]
    pos: list[np.ndarray] = []
    nrm: list[np.ndarray] = []
    col: list[np.ndarray] = []
    for (a, b), (c, d) in rects:
        poly = np.array([[a, b], [c, b], [c, d], [a, d]])
        _prism(poly, 0.0, height, kind_colour("boundary"), band=None, pos=pos, nrm=nrm, col=col)
    return _verts(pos, nrm, col)


def floor_vertices(world: WorldConfig, *, margin: float = FLOOR_MARGIN) -> np.ndarray:
    (x0, y0), (x1, y1) = world.bounds
    a, b, c, d = x0 - margin, y0 - margin, x1 + margin, y1 + margin
    quad = [
        np.array(p, dtype=np.float64)
        for p in ((a, 0, b), (a, 0, d), (c, 0, d), (a, 0, b), (c, 0, d), (c, 0, b))
    ]
    up = np.array([0.0, 1.0, 0.0])
    return _verts(quad, [up] * 6, [linear(FLOOR_COLOUR)] * 6)


def door_frame_vertices(door: Door, world: WorldConfig) -> np.ndarray:
    """A doorway's frame: a post at each jamb and a lintel from the leaf's top up to the
    tallest obstacle touching a jamb (a wall over the door), or 0.25 m above the leaf."""
    a, b = np.asarray(door.span[0], np.float64), np.asarray(door.span[1], np.float64)
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([-t[1], t[0]])
    jambs = [shapely.Point(*a), shapely.Point(*b)]
    walls = [o.height for o in world.obstacles
             if any(shapely.Polygon(o.vertices).distance(j) < 0.05 for j in jambs)]
    top = max([door.height + 0.25, *walls])
    pos: list[np.ndarray] = []
    nrm: list[np.ndarray] = []
    col: list[np.ndarray] = []
    colour = kind_colour("door_frame")
    d = LEAF_THICKNESS / 2 + FRAME
    for end, inward in ((a, t), (b, -t)):
        post = [end - d * n, end + FRAME * inward - d * n, end + FRAME * inward + d * n, end + d * n]
        _prism(_ccw(np.asarray(post)), 0.0, door.height, colour, band=None, pos=pos, nrm=nrm, col=col)
    lintel = _ccw(np.asarray([a - d * n, b - d * n, b + d * n, a + d * n]))
    _prism(lintel, door.height, top, colour, band=None, pos=pos, nrm=nrm, col=col, bottom=True)
    return _verts(pos, nrm, col)


def door_leaf_vertices(length: float, height: float) -> np.ndarray:
    """One leaf in its own frame: hinge at the origin, closed along +x, a glass panel at eye
    height. :func:`place_leaves` turns it to the leaf's angle every frame."""
    pos: list[np.ndarray] = []
    nrm: list[np.ndarray] = []
    col: list[np.ndarray] = []
    h = LEAF_THICKNESS / 2
    poly = np.array([[0.01, -h], [length - 0.005, -h], [length - 0.005, h], [0.01, h]])
    _prism(poly, 0.01, height, kind_colour("door"), band=LEAF_GLAZING, pos=pos, nrm=nrm, col=col)
    return _verts(pos, nrm, col)


def place_leaves(local: list[np.ndarray], pose: np.ndarray) -> np.ndarray:
    """All leaves in world space: ``local[i]`` (from :func:`door_leaf_vertices`) turned about
    its hinge to ``pose[i]`` (hinge x, hinge y, world angle, ...: ``DoorLeaves.pose()``)."""
    parts = []
    for v, (hx, hy, ang, *_) in zip(local, np.asarray(pose, np.float64), strict=True):
        c, s = np.cos(ang), np.sin(ang)
        out = v.copy()
        for key in ("pos", "normal"):
            x, z = v[key][:, 0], v[key][:, 2]
            out[key][:, 0] = c * x - s * z + (hx if key == "pos" else 0.0)
            out[key][:, 2] = s * x + c * z + (hy if key == "pos" else 0.0)
        parts.append(out)
    return np.concatenate(parts) if parts else np.zeros(0, dtype=ENV_DTYPE)


def _ccw(poly: np.ndarray) -> np.ndarray:
    x, y = poly[:, 0], poly[:, 1]
    area = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    return poly if area > 0 else poly[::-1]


def environment_mesh(world: WorldConfig) -> EnvironmentMesh:
    """Everything static in ``world``: the floor, and the boundary, every obstacle and every
    door frame (the leaves move: :func:`place_leaves`)."""
    parts = ([boundary_vertices(world)] + [obstacle_vertices(o) for o in world.obstacles]
             + [door_frame_vertices(d, world) for d in world.doors])
    return EnvironmentMesh(floor=floor_vertices(world), solids=np.concatenate(parts))


def sphere_vertices(*, colour: tuple[float, float, float] = (0.9, 0.05, 0.04)) -> np.ndarray:
    """A unit-diameter sphere (scaled by the model matrix): the red target sphere."""
    p, n = unit_sphere(rings=12, sectors=20)
    v = np.zeros(len(p), dtype=ENV_DTYPE)
    v["pos"], v["normal"], v["color"] = p, n, linear(colour)
    return v


def unit_sphere(*, rings: int = 8, sectors: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of a sphere of radius 0.5 (positions, normals), counter-clockwise outside."""
    pos = []
    for r in range(rings):
        t0, t1 = math.pi * r / rings, math.pi * (r + 1) / rings
        for s in range(sectors):
            p0, p1 = 2 * math.pi * s / sectors, 2 * math.pi * (s + 1) / sectors

            def pt(t: float, p: float) -> np.ndarray:
                return np.array([math.sin(t) * math.cos(p), math.cos(t), -math.sin(t) * math.sin(p)])

            a, b, c, d = pt(t0, p0), pt(t1, p0), pt(t1, p1), pt(t0, p1)
            if r > 0:
                pos += [a, b, d]
            if r < rings - 1:
                pos += [d, b, c]
    n = np.asarray(pos)
    return n * 0.5, n
