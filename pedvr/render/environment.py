"""Static scene geometry from the scene's polygons (pure numpy and shapely, no GL).

The floor with its markings (crosswalks), walls along the world bounds
(indoors at the scene's wall height, with an optional ceiling; outdoors a
barrier one can see over: the border acts as a wall in the simulation), and
every obstacle extruded from its counter-clockwise polygon to its height,
shaped by ``kind``: walls and pillars full height; tables a top slab on a
leg; counters solid; booths a counter at 1.05 m with a banner panel up to
their height (so aisles stay visible, issue 16); shops a glazed front under a
coloured fascia; buildings a façade with windows; plants a pot under
stacked foliage (PLACE's partial occluder). Exhibits (the demonstrators'
smart objects, :mod:`pedvr.demonstrator`) stand on whatever they are on as
small glazed vases, or on a slim stand in the open. Vertices are
``(position, normal, linear RGB colour, uv, material)`` in world space (ground
``(x, y)`` → ``(x, 0, y)``, :mod:`pedvr.render.math3d`); the environment
shader draws each material's procedural texture from ``uv`` (metres).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from pedvr.behavior.spec import ObjectDef
from pedvr.scene.config import Door, Obstacle, WorldConfig

ENV_DTYPE = np.dtype([("pos", "<f4", 3), ("normal", "<f4", 3), ("color", "<f4", 3), ("uv", "<f4", 2),
                      ("material", "<i4")])
ENV_FORMAT = ("3f 3f 3f 2f 1i", "in_pos", "in_normal", "in_color", "in_uv", "in_material")
# Materials (shaders/environment.glsl draws each procedurally from uv: metres along a wall's
# perimeter and up it, or across and along a marking).
PAINT, FLOOR, PLASTER, GLASS_MAT, WOOD, FACADE, FABRIC, ASPHALT, MARKING, CONCRETE, METAL, CEILING = range(12)
FLOOR_PATTERNS = {"grid": 0, "tiles": 1, "wood": 2, "carpet": 3, "asphalt": 4, "paving": 5}
COUNTER_HEIGHT = 1.05  # m: booths are counters at this height with a banner panel (issue 16)
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
    "building": (0.72, 0.66, 0.58),
    "shop": (0.78, 0.70, 0.55),
    "boundary": (0.55, 0.53, 0.50),
    "door": (0.56, 0.40, 0.26),
    "door_frame": (0.35, 0.33, 0.32),
    "plant": (0.22, 0.42, 0.18),
    "pot": (0.62, 0.33, 0.22),
}
POT_HEIGHT = 0.35  # m, a plant's pot
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
    """Vertices of the floor (and its markings), of everything that casts shadows, and of the
    ceiling (which does not: the key light shines through it)."""

    floor: np.ndarray
    solids: np.ndarray
    ceiling: np.ndarray


def _verts(pos: list[np.ndarray], nrm: list[np.ndarray], col: list[np.ndarray],
           uv: list[np.ndarray] | None = None, mat: list[int] | None = None) -> np.ndarray:
    v = np.zeros(len(pos), dtype=ENV_DTYPE)
    if pos:
        v["pos"], v["normal"], v["color"] = np.asarray(pos), np.asarray(nrm), np.asarray(col)
        if uv:
            v["uv"] = np.asarray(uv)
        if mat:
            v["material"] = np.asarray(mat)
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


class _Parts:
    """Vertex lists of a mesh being built: positions, normals, colours, uv, materials."""

    def __init__(self) -> None:
        self.pos: list[np.ndarray] = []
        self.nrm: list[np.ndarray] = []
        self.col: list[np.ndarray] = []
        self.uv: list[np.ndarray] = []
        self.mat: list[int] = []

    def add(self, p: list[np.ndarray], n: np.ndarray, c: np.ndarray, uv: list[np.ndarray], m: int) -> None:
        self.pos += p
        self.nrm += [n] * len(p)
        self.col += [c] * len(p)
        self.uv += uv
        self.mat += [m] * len(p)

    def verts(self) -> np.ndarray:
        return _verts(self.pos, self.nrm, self.col, self.uv, self.mat)


def _prism(
    poly: np.ndarray,
    y0: float,
    y1: float,
    colour: np.ndarray,
    out: _Parts,
    *,
    material: int = PAINT,
    band: tuple[float, float] | None = None,
    band_material: int = GLASS_MAT,
    top: bool = True,
    bottom: bool = False,
    top_material: int | None = None,
) -> None:
    """Sides (split at ``band`` into facade / glass / facade) and caps of a vertical prism.

    Sides get uv = (metres along the perimeter, height), caps uv = ground (x, y).
    """
    poly = np.asarray(poly, dtype=np.float64)
    cuts = [y0, y1]
    if band is not None:
        cuts = sorted({y0, y1, *(min(max(b, y0), y1) for b in band)})
    glass = linear(GLASS)
    n = len(poly)
    along = 0.0
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
            in_band = band is not None and band[0] <= lo and hi <= band[1]
            c = glass if in_band and band_material == GLASS_MAT else colour
            m = band_material if in_band else material
            a0, b0 = np.array([a[0], lo, a[1]]), np.array([b[0], lo, b[1]])
            a1, b1 = np.array([a[0], hi, a[1]]), np.array([b[0], hi, b[1]])
            ua0, ub0 = np.array([along, lo]), np.array([along + length, lo])
            ua1, ub1 = np.array([along, hi]), np.array([along + length, hi])
            tri, uv = [a0, b0, b1, a0, b1, a1], [ua0, ub0, ub1, ua0, ub1, ua1]
            if np.dot(np.cross(b0 - a0, b1 - a0), normal) < 0:
                tri, uv = [a0, b1, b0, a0, a1, b1], [ua0, ub1, ub0, ua0, ua1, ub1]
            out.add(tri, normal, c, uv, m)
        along += length
    tris = _cap_triangles(poly)
    for y, up in ((y1, True), (y0, False)):
        if (up and not top) or (not up and not bottom):
            continue
        normal = np.array([0.0, 1.0 if up else -1.0, 0.0])
        for t in tris:
            p3 = [np.array([q[0], y, q[1]]) for q in t]
            if np.dot(np.cross(p3[1] - p3[0], p3[2] - p3[0]), normal) < 0:
                p3 = p3[::-1]
            out.add(p3, normal, colour, [np.array([q[0], q[2]]) for q in p3],
                    material if top_material is None or not up else top_material)


_KIND_MATERIAL = {"wall": PLASTER, "pillar": CONCRETE, "building": FACADE, "shop": PLASTER, "box": PAINT,
                  "counter": FABRIC, "polygon": PAINT}


def _hash_colour(x: float, y: float) -> np.ndarray:
    """A stable bright colour from a position (booth fabrics, shop signs)."""
    h = (math.sin(x * 12.9898 + y * 78.233) * 43758.5453) % 1.0
    palette = [(0.75, 0.2, 0.2), (0.2, 0.45, 0.75), (0.25, 0.6, 0.35), (0.85, 0.65, 0.2), (0.55, 0.3, 0.65),
               (0.9, 0.45, 0.15), (0.2, 0.6, 0.65)]
    return linear(palette[int(h * len(palette)) % len(palette)])


def obstacle_vertices(ob: Obstacle) -> np.ndarray:
    """The extruded geometry of one obstacle, by kind (issue 16: booths are counters with a banner,
    shops have glazed fronts under a coloured fascia, buildings have windows)."""
    out = _Parts()
    poly = np.asarray(ob.vertices, dtype=np.float64)
    colour = kind_colour(ob.kind)
    h = ob.height
    if ob.kind == "table":
        _prism(poly, max(h - TABLE_TOP, 0.0), h, colour, out, material=WOOD, bottom=True)
        c = poly.mean(axis=0)
        r = min(0.06, 0.25 * float(np.min(np.ptp(poly, axis=0))))
        leg = c + np.array([[-r, -r], [r, -r], [r, r], [-r, r]])
        _prism(leg, 0.0, max(h - TABLE_TOP, 0.0), linear((0.3, 0.3, 0.32)), out, material=METAL, top=False)
    elif ob.kind == "booth":
        c = poly.mean(axis=0)
        fabric = _hash_colour(float(c[0]), float(c[1]))
        top = min(h, COUNTER_HEIGHT)
        _prism(poly, 0.0, top, fabric, out, material=FABRIC, top_material=WOOD)
        if h > COUNTER_HEIGHT + 0.2:
            # A banner panel along the booth's long axis, 1.2 m wide at most, up to the booth's height.
            ext = np.ptp(poly, axis=0)
            ax = 0 if ext[0] >= ext[1] else 1
            half = min(0.6, 0.3 * float(ext[ax]))
            d = np.zeros(2)
            d[ax] = half
            nrm = np.zeros(2)
            nrm[1 - ax] = 0.03
            panel = _ccw(np.array([c - d - nrm, c + d - nrm, c + d + nrm, c - d + nrm]))
            _prism(panel, top, h - 0.45, linear((0.9, 0.9, 0.88)), out, material=FABRIC, top=False)
            _prism(panel, h - 0.45, h, fabric, out, material=FABRIC)
    elif ob.kind == "plant":
        c = poly.mean(axis=0)
        pot = min(POT_HEIGHT, 0.3 * h)
        _prism(c + 0.6 * (poly - c), 0.0, pot, kind_colour("pot"), out, material=PAINT)
        # foliage: three tiers, widest in the middle, each a little turned
        for k, (lo, hi, w) in enumerate(((pot, 0.55 * h, 0.85), (0.45 * h, 0.8 * h, 1.0), (0.7 * h, h, 0.6))):
            a = 0.4 * k
            rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
            tier = c + ((poly - c) @ rot.T) * w
            _prism(_ccw(tier), lo, hi, colour * (0.85 + 0.15 * k), out, material=FABRIC)
    elif ob.kind == "shop" and h > GLAZING[1]:
        _prism(poly, 0.0, h, colour, out, material=PLASTER, band=GLAZING)
        # The fascia: a coloured sign band above the glazing.
        c = poly.mean(axis=0)
        fascia = _hash_colour(float(c[0]), float(c[1]))
        n0 = len(out.pos)
        _prism(poly, GLAZING[1] + 0.15, min(h, GLAZING[1] + 0.55), fascia, out, material=PAINT, top=False)
        for k in range(n0, len(out.pos)):  # pushed out a little so it does not fight the wall
            out.pos[k] = out.pos[k] + out.nrm[k] * 0.01
    else:
        _prism(poly, 0.0, h, colour, out, material=_KIND_MATERIAL.get(ob.kind, PAINT))
    return out.verts()


def boundary_vertices(
    world: WorldConfig, *, height: float | None = None, thickness: float = 0.15
) -> np.ndarray:
    """Walls just outside the world bounds (four thin prisms): indoors ``world.wall_height`` of
    plaster, outdoors a concrete barrier one can see over."""
    (x0, y0), (x1, y1) = world.bounds
    t = thickness
    if height is None:
        height = world.wall_height if world.indoor else BOUNDARY_HEIGHT
    rects = [
        ((x0 - t, y0 - t), (x1 + t, y0)),
        ((x0 - t, y1), (x1 + t, y1 + t)),
        ((x0 - t, y0), (x0, y1)),
        ((x1, y0), (x1 + t, y1)),
    ]
    out = _Parts()
    colour = kind_colour("wall" if world.indoor else "boundary")
    for (a, b), (c, d) in rects:
        poly = np.array([[a, b], [c, b], [c, d], [a, d]])
        _prism(poly, 0.0, height, colour, out, material=PLASTER if world.indoor else CONCRETE)
    return out.verts()


def floor_vertices(world: WorldConfig, *, margin: float = FLOOR_MARGIN) -> np.ndarray:
    """The floor (indoors the room itself, outdoors beyond the bounds too) and its markings."""
    (x0, y0), (x1, y1) = world.bounds
    m = 0.2 if world.indoor else margin
    a, b, c, d = x0 - m, y0 - m, x1 + m, y1 + m
    quad = [np.array(p, dtype=np.float64)
            for p in ((a, 0, b), (a, 0, d), (c, 0, d), (a, 0, b), (c, 0, d), (c, 0, b))]
    out = _Parts()
    out.add(quad, np.array([0.0, 1.0, 0.0]), linear(FLOOR_COLOUR), [q[[0, 2]] for q in quad], FLOOR)
    for mk in world.markings:
        p, q = np.asarray(mk.start, np.float64), np.asarray(mk.end, np.float64)
        along = (q - p) / np.linalg.norm(q - p)
        across = np.array([-along[1], along[0]]) * mk.width / 2
        length = float(np.linalg.norm(q - p))
        corners = [p - across, p + across, q + across, q - across]
        uvs = [np.array([-mk.width / 2, 0.0]), np.array([mk.width / 2, 0.0]),
               np.array([mk.width / 2, length]), np.array([-mk.width / 2, length])]
        pts = [np.array([c2[0], 0.006, c2[1]]) for c2 in corners]
        tri = [0, 1, 2, 0, 2, 3]
        if np.cross(pts[1] - pts[0], pts[2] - pts[0])[1] < 0:  # counter-clockwise seen from above
            tri = [0, 2, 1, 0, 3, 2]
        out.add([pts[i] for i in tri], np.array([0.0, 1.0, 0.0]), linear((0.92, 0.92, 0.9)),
                [uvs[i] for i in tri], MARKING)
    return out.verts()


def ceiling_vertices(world: WorldConfig) -> np.ndarray:
    """A ceiling at ``world.wall_height`` over the bounds, facing down (only with ``world.ceiling``)."""
    if not world.ceiling:
        return np.zeros(0, dtype=ENV_DTYPE)
    (x0, y0), (x1, y1) = world.bounds
    y = world.wall_height
    quad = [np.array(p, dtype=np.float64)
            for p in ((x0, y, y0), (x1, y, y1), (x0, y, y1), (x0, y, y0), (x1, y, y0), (x1, y, y1))]
    out = _Parts()
    out.add(quad, np.array([0.0, -1.0, 0.0]), linear((0.9, 0.9, 0.88)), [q[[0, 2]] for q in quad], CEILING)
    return out.verts()


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
    out = _Parts()
    colour = kind_colour("door_frame")
    d = LEAF_THICKNESS / 2 + FRAME
    for end, inward in ((a, t), (b, -t)):
        post = [end - d * n, end + FRAME * inward - d * n, end + FRAME * inward + d * n, end + d * n]
        _prism(_ccw(np.asarray(post)), 0.0, door.height, colour, out, material=METAL)
    lintel = _ccw(np.asarray([a - d * n, b - d * n, b + d * n, a + d * n]))
    _prism(lintel, door.height, top, kind_colour("wall"), out, material=PLASTER, bottom=True)
    return out.verts()


def door_leaf_vertices(length: float, height: float) -> np.ndarray:
    """One leaf in its own frame: hinge at the origin, closed along +x, a glass panel at eye
    height. :func:`place_leaves` turns it to the leaf's angle every frame."""
    out = _Parts()
    h = LEAF_THICKNESS / 2
    poly = np.array([[0.01, -h], [length - 0.005, -h], [length - 0.005, h], [0.01, h]])
    _prism(poly, 0.01, height, kind_colour("door"), out, material=WOOD, band=LEAF_GLAZING)
    return out.verts()


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


@dataclass(frozen=True)
class ExhibitShape:
    """An exhibit as drawn: ground point, the height it stands on, its top, its width (m)."""

    at: tuple[float, float]
    base: float
    top: float
    size: float


def exhibit_shapes(world: WorldConfig, objects: Sequence[ObjectDef]) -> list[ExhibitShape]:
    """The scene's exhibits (smart objects of kind ``exhibit``) as drawn: on the obstacle under
    them (a table, a pedestal) up to their ``height`` (default 0.1 m above it, as the demonstrator
    plans), or in the open on a stand."""
    out = []
    for o in objects:
        if o.kind != "exhibit":
            continue
        size = float(o.params.get("size", 0.1))
        p = shapely.Point(o.at)
        under = [ob.height for ob in world.obstacles if shapely.Polygon(ob.vertices).contains(p)]
        base = under[0] if under else 0.0
        top = float(o.params.get("height", base + 0.1 if under else 1.0))
        if not under:
            base = max(top - max(size, 0.1), 0.0)
        out.append(ExhibitShape(at=o.at, base=base, top=max(top, base + 0.02), size=size))
    return out


def exhibit_vertices(ex: ExhibitShape) -> np.ndarray:
    """A small glazed vase (octagonal, waisted) from ``base`` to ``top``, coloured by its place; in
    the open, a slim dark stand below it."""
    out = _Parts()
    c = np.asarray(ex.at, np.float64)
    r = 0.5 * max(ex.size, 0.04)
    ring = np.array([[math.cos(2 * math.pi * (k + 0.5) / 8), math.sin(2 * math.pi * (k + 0.5) / 8)]
                     for k in range(8)])
    colour = _hash_colour(float(c[0]), float(c[1]))
    h = ex.top - ex.base
    for lo, hi, w in ((0.0, 0.55, 1.0), (0.55, 0.8, 0.55), (0.8, 1.0, 0.75)):
        _prism(c + ring * r * w, ex.base + lo * h, ex.base + hi * h, colour, out, material=PAINT)
    return out.verts()


def stand_vertices(ex: ExhibitShape) -> np.ndarray:
    """A slim stand from the floor to an exhibit's base (exhibits shown in the open)."""
    out = _Parts()
    c = np.asarray(ex.at, np.float64)
    sq = np.array([[-0.04, -0.04], [0.04, -0.04], [0.04, 0.04], [-0.04, 0.04]])
    _prism(c + sq, 0.0, ex.base, linear((0.2, 0.2, 0.22)), out, material=METAL)
    plate = np.array([[-0.12, -0.12], [0.12, -0.12], [0.12, 0.12], [-0.12, 0.12]])
    _prism(c + plate, max(ex.base - 0.02, 0.0), ex.base, linear((0.2, 0.2, 0.22)), out, material=METAL)
    return out.verts()


def environment_mesh(world: WorldConfig, exhibits: Sequence[ExhibitShape] = ()) -> EnvironmentMesh:
    """Everything static in ``world``: the floor, and the boundary, every obstacle and every
    door frame (the leaves move: :func:`place_leaves`), and the exhibits."""
    on_floor = [e for e in exhibits if not any(shapely.Polygon(o.vertices).contains(shapely.Point(e.at))
                                               for o in world.obstacles)]
    parts = ([boundary_vertices(world)] + [obstacle_vertices(o) for o in world.obstacles]
             + [door_frame_vertices(d, world) for d in world.doors]
             + [exhibit_vertices(e) for e in exhibits] + [stand_vertices(e) for e in on_floor])
    return EnvironmentMesh(floor=floor_vertices(world), solids=np.concatenate(parts),
                           ceiling=ceiling_vertices(world))


def sphere_vertices(*, colour: tuple[float, float, float] = (0.9, 0.05, 0.04)) -> np.ndarray:
    """A unit-diameter sphere (scaled by the model matrix): the red target sphere."""
    p, n = unit_sphere(rings=12, sectors=20)
    v = np.zeros(len(p), dtype=ENV_DTYPE)
    v["pos"], v["normal"], v["color"], v["material"] = p, n, linear(colour), PAINT
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
