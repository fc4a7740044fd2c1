"""The navigation mesh: free space shrunk by a clearance, triangulated.

``NavMesh.build(world, clearance=r)`` takes the walkable area (bounds minus
obstacles), shrinks it by ``r`` so that any point of the mesh is a valid
position for the centre of a disc of radius ``r``, and triangulates it with
GEOS's constrained Delaunay triangulation. Paths are A* over triangles, then
the funnel (see :mod:`pedvr.world.pathing`). Units are metres.

Shrinking uses round joins, so a gap between two obstacles stays open exactly
when a disc fits through it (mitre joins would close diagonal gaps up to
``2*sqrt(2)*r`` wide). GEOS draws each rounded corner as chords whose ends lie
on the circle, and the chords dip inside it; so a regular polygon *around* the
disc (``4 * quad_segs`` sides, apothem ``r``) is also cut out at every vertex
of the walkable area. The mesh is thus exact along straight walls and at most
``r * (1/cos(pi / (4 * quad_segs)) - 1)`` conservative at obstacle corners
(2 % of ``r`` at the default ``quad_segs=4``: 5 mm for r = 0.25 m).

Narrow passages (issue 26): people pass gaps narrower than their shoulders by
turning them (real people pass 0.5 m; a turned body is ``narrow`` deep, 0.13 m
for r = 0.25 m, :mod:`pedvr.crowd.footprint`), but the mesh shrunk by ``r``
closes such a gap. ``NavMesh.build(world, clearance=r, narrow=b)`` adds back the
gaps the full radius closes and a body ``b`` deep fits through: the *necks* of
the area shrunk by ``b`` that the area shrunk by ``r`` misses, each one's part of
the ``b``-shrunk area within ``r - b`` of it (so it joins the ``r`` mesh on both
sides). A neck is a piece of ``erode(W, b) − erode(W, r) ⊕ (r − b)`` (what a
body ``b`` deep reaches but a disc of radius ``r`` does not) that touches the
``r`` mesh in two or more places: the pieces that touch it once are the corners
a disc cannot fill, not passages. Triangles in a neck are ``narrow``; A* counts
the way through them ``NARROW_COST`` times its length (a queue forms there, and
a turned body walks slower), so a narrow passage is taken when the way round is
more than that much longer. On the mesh, a point is at least ``clearance`` from
every obstacle except in a neck, where it is at least ``narrow``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

from pedvr.errors import NavigationError
from pedvr.scene.config import WorldConfig
from pedvr.world import mesh_kernels as mk
from pedvr.world.geometry import polygons_of, walkable_area
from pedvr.world.pathing import astar_corridor, corridor_portals, funnel, path_length

# How far (metres) a snapped point is moved inside its triangle.
SNAP_INSET = 0.002
NARROW_COST = 3.0  # A*'s cost per metre through a narrow passage, per metre elsewhere
_NECK_OVERLAP = 0.01  # m: a neck's part reaches this far into the r mesh, so the two join
_REGION_CACHE_SIZE = 64


def _fmt(p: np.ndarray) -> str:
    return f"({p[0]:.3f}, {p[1]:.3f})"


def _as_point(p: object, what: str) -> np.ndarray:
    a = np.asarray(p, dtype=np.float64).reshape(-1)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise NavigationError(f"{what} = {p!r}: must be a finite (x, y) point")
    return a


def _erode(area: Polygon | MultiPolygon, r: float, quad_segs: int) -> Polygon | MultiPolygon:
    """Points of ``area`` at least ``r`` from its boundary (up to the corner cut, see module doc)."""
    eroded = area.buffer(-r, quad_segs=quad_segs, join_style="round")
    if eroded.is_empty:
        return eroded
    corners = shapely.get_coordinates(area.boundary)
    n = 4 * quad_segs
    # Circumradius of the n-gon whose apothem is r; its vertices lie on that circle.
    cut = shapely.buffer(shapely.points(corners), r / math.cos(math.pi / n), quad_segs=quad_segs)
    result = shapely.normalize(eroded.difference(shapely.union_all(cut)))
    parts = [g for g in shapely.get_parts(result) if isinstance(g, Polygon) and g.area > 0.0]
    return parts[0] if len(parts) == 1 else MultiPolygon(parts)


def _necks(area: Polygon | MultiPolygon, wide: Polygon | MultiPolygon, r: float, b: float,
           quad_segs: int) -> Polygon | MultiPolygon | None:
    """The narrow passages of ``area`` (the walkable area) a body ``b`` deep fits through and a
    disc of radius ``r`` does not, each grown to join ``wide`` (``area`` shrunk by ``r``) on its
    sides; None when there are none (see the module docstring)."""
    thin = _erode(area, b, quad_segs)
    if thin.is_empty:
        return None
    reach = wide.buffer(r - b, quad_segs=quad_segs) if not wide.is_empty else wide
    left = thin.difference(reach)
    grow = r - b + _NECK_OVERLAP
    out = []
    for piece in shapely.get_parts(left):
        if not isinstance(piece, Polygon) or piece.area <= 1e-9:
            continue
        near = piece.buffer(grow, quad_segs=quad_segs)
        if len([g for g in shapely.get_parts(wide.intersection(near)) if g.area > 1e-9]) < 2:
            continue  # touches the wide mesh once: a corner a disc cannot fill, not a passage
        out.append(near.intersection(thin))
    if not out:
        return None
    return shapely.union_all(out)


def _triangulate(area: Polygon | MultiPolygon) -> tuple[np.ndarray, np.ndarray]:
    """Constrained Delaunay triangles of ``area`` as ``(verts (V,2), tris (T,3))``.

    GEOS triangulates holes correctly; triangles whose centroid is outside
    ``area`` (none expected) and degenerate ones are dropped anyway.
    Triangles are made counter-clockwise; vertex order is lexicographic.
    """
    if area.is_empty:
        return np.zeros((0, 2)), np.zeros((0, 3), np.int64)
    parts = shapely.get_parts(shapely.constrained_delaunay_triangles(area))
    if len(parts) == 0:
        return np.zeros((0, 2)), np.zeros((0, 3), np.int64)
    coords = shapely.get_coordinates(parts).reshape(len(parts), 4, 2)[:, :3, :]
    a, b, c = coords[:, 0], coords[:, 1], coords[:, 2]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    centroid = coords.mean(axis=1)
    keep = (np.abs(cross) > 1e-12) & shapely.contains_xy(area, centroid[:, 0], centroid[:, 1])
    coords, cross = coords[keep], cross[keep]
    # Make every triangle CCW.
    cw = cross < 0.0
    coords[cw] = coords[cw][:, ::-1]
    verts, inverse = np.unique(coords.reshape(-1, 2), axis=0, return_inverse=True)
    tris = inverse.reshape(-1, 3).astype(np.int64)
    return np.ascontiguousarray(verts), np.ascontiguousarray(tris)


def _adjacency(tris: np.ndarray) -> np.ndarray:
    """``neighbors[t, k]``: the triangle across edge ``tris[t,k] -> tris[t,(k+1)%3]``, or -1."""
    n = tris.shape[0]
    neighbors = np.full((n, 3), -1, np.int64)
    if n == 0:
        return neighbors
    a = tris.reshape(-1)
    b = tris[:, [1, 2, 0]].reshape(-1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.lexsort((hi, lo))
    lo_s, hi_s = lo[order], hi[order]
    same = (lo_s[1:] == lo_s[:-1]) & (hi_s[1:] == hi_s[:-1])
    for j in np.flatnonzero(same):
        e1, e2 = order[j], order[j + 1]
        neighbors[e1 // 3, e1 % 3] = e2 // 3
        neighbors[e2 // 3, e2 % 3] = e1 // 3
    return neighbors


@dataclass(frozen=True, eq=False)
class NavMesh:
    """A triangulated walkable area for discs of radius ``clearance``.

    Arrays (read-only by convention):

    - ``verts (V, 2) float64``: mesh vertices, m.
    - ``tris (T, 3) int64``: counter-clockwise vertex indices.
    - ``neighbors (T, 3) int64``: triangle across edge ``k`` (``tris[t,k] ->
      tris[t,(k+1)%3]``), -1 on the boundary; shared edges are the portals.
    - ``components (T,) int64``: connected part of each triangle, 0-based.
    - ``tri_area (T,) float64``: m².

    - ``narrow (T,) bool``: the triangle lies in a narrow passage (only meshes built
      with ``narrow``; see the module docstring).

    ``polygon`` is the shrunk walkable area the mesh covers. Queries take
    points as anything array-like of shape (2,); points outside the mesh are
    snapped (see :meth:`nearest_walkable`). Build with :meth:`build`.
    """

    clearance: float
    polygon: Polygon | MultiPolygon
    verts: np.ndarray = field(repr=False)
    tris: np.ndarray = field(repr=False)
    neighbors: np.ndarray = field(repr=False)
    components: np.ndarray = field(repr=False)
    tri_area: np.ndarray = field(repr=False)
    _grid: tuple[np.ndarray, float, int, int, np.ndarray, np.ndarray] = field(repr=False)
    _boundary: tuple[np.ndarray, np.ndarray, np.ndarray] = field(repr=False)
    _region_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = field(
        default_factory=dict, repr=False
    )
    narrow: np.ndarray = field(default_factory=lambda: np.zeros(0, np.bool_), repr=False)
    narrow_clearance: float | None = None

    @classmethod
    def build(cls, world: WorldConfig, clearance: float, *, narrow: float | None = None,
              quad_segs: int = 4) -> NavMesh:
        """Build the mesh of ``world`` for discs of radius ``clearance`` (m, >= 0).

        ``narrow`` (m, in (0, clearance)): also the passages a body that deep fits through
        (see the module doc). ``quad_segs`` is the number of chords per quarter circle at
        rounded corners (see the module doc). Raises :class:`NavigationError` when
        ``clearance`` is negative or not finite, ``narrow`` is outside (0, clearance), or
        nothing is walkable.
        """
        if not (math.isfinite(clearance) and clearance >= 0.0):
            raise NavigationError(f"clearance = {clearance}: must be a finite number >= 0")
        if narrow is not None and not (math.isfinite(narrow) and 0.0 < narrow < clearance):
            raise NavigationError(f"narrow = {narrow}: must be a number in (0, clearance = {clearance})")
        if quad_segs < 1:
            raise NavigationError(f"quad_segs = {quad_segs}: must be >= 1")
        walk = walkable_area(world)
        area = walk
        if clearance > 0.0:
            area = _erode(walk, clearance, quad_segs)
        necks = None if narrow is None else _necks(walk, area, clearance, narrow, quad_segs)
        if necks is not None:
            area = shapely.normalize(shapely.union(area, necks))
        polys = [p for p in polygons_of(area) if isinstance(p, Polygon)]  # type: ignore[arg-type]
        shrunk: Polygon | MultiPolygon = polys[0] if len(polys) == 1 else MultiPolygon(polys)
        verts, tris = _triangulate(shrunk)
        if tris.shape[0] == 0:
            raise NavigationError(
                f"world with bounds {world.bounds} has no walkable area for clearance "
                f"{clearance} m"
            )
        neighbors = _adjacency(tris)
        n = tris.shape[0]
        rows = np.repeat(np.arange(n), 3)
        cols = neighbors.reshape(-1)
        ok = cols >= 0
        graph = coo_matrix((np.ones(ok.sum()), (rows[ok], cols[ok])), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
        tri_area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                          - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
        # Uniform grid for point location: about two cells per triangle.
        lo = verts.min(axis=0)
        ext = np.maximum(verts.max(axis=0) - lo, 1e-6)
        h = max(math.sqrt(ext[0] * ext[1] / (2.0 * n)), 1e-6, float(ext.max()) / 2048.0)
        nx, ny = int(ext[0] // h) + 1, int(ext[1] // h) + 1
        origin = np.ascontiguousarray(lo)
        cell_start, cell_tris = mk.build_grid(verts, tris, origin, h, nx, ny)
        # Boundary edges (no neighbour) with their triangle, for snapping.
        bt, bk = np.nonzero(neighbors < 0)
        ba = np.ascontiguousarray(verts[tris[bt, bk]])
        bb = np.ascontiguousarray(verts[tris[bt, (bk + 1) % 3]])
        in_neck = np.zeros(n, np.bool_)
        if necks is not None:
            centre = verts[tris].mean(axis=1)
            wide = area if clearance <= 0.0 else _erode(walk, clearance, quad_segs)
            in_neck = ~shapely.contains_xy(wide, centre[:, 0], centre[:, 1])
        return cls(
            clearance=float(clearance),
            polygon=shrunk,
            verts=verts,
            tris=tris,
            neighbors=neighbors,
            components=labels.astype(np.int64),
            tri_area=tri_area,
            _grid=(origin, h, nx, ny, cell_start, cell_tris),
            _boundary=(ba, bb, bt.astype(np.int64)),
            narrow=in_neck,
            narrow_clearance=None if narrow is None else float(narrow),
        )

    # -- queries -----------------------------------------------------------

    @property
    def _cost(self) -> np.ndarray | None:
        """A*'s cost per metre in each triangle (None: 1 everywhere)."""
        if not self.narrow.any():
            return None
        return np.where(self.narrow, NARROW_COST, 1.0)

    @property
    def area(self) -> float:
        """Total area of the mesh (the shrunk walkable area), m²."""
        return float(self.tri_area.sum())

    @property
    def n_components(self) -> int:
        """Number of connected parts of the mesh."""
        return int(self.components.max()) + 1

    def locate(self, points: np.ndarray) -> np.ndarray:
        """Triangle index of each of ``points (N, 2)``, or -1 outside the mesh.

        Points within 1e-9 m of a triangle count as inside it; a point on an
        edge shared by two triangles gets the lower index. Returns ``(N,)``
        int64. Vectorised and parallel; NaN points give -1.
        """
        pts = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 2))
        out = np.empty(pts.shape[0], np.int64)
        origin, h, nx, ny, cell_start, cell_tris = self._grid
        mk.locate_points(pts, self.verts, self.tris, origin, h, nx, ny, cell_start, cell_tris, out)
        return out

    def contains(self, p: object) -> bool:
        """Whether point ``p`` lies on the mesh (within 1e-9 m)."""
        return bool(self.locate(_as_point(p, "point"))[0] >= 0)

    def _snap(self, p: np.ndarray) -> tuple[np.ndarray, int]:
        t = int(self.locate(p)[0])
        if t >= 0:
            return p, t
        ba, bb, bt = self._boundary
        k, qx, qy = mk.nearest_on_edges(float(p[0]), float(p[1]), ba, bb)
        t = int(bt[k])
        q = np.array([qx, qy])
        centroid = self.verts[self.tris[t]].mean(axis=0)
        d = centroid - q
        dist = float(np.hypot(d[0], d[1]))
        # Step inside toward the centroid: the triangle is convex, so this stays in it.
        q = q + d * (min(SNAP_INSET, 0.5 * dist) / dist) if dist > 0.0 else q
        t2 = int(self.locate(q)[0])
        return (q, t2) if t2 >= 0 else (centroid, t)

    def nearest_walkable(self, p: object) -> tuple[float, float]:
        """``p`` itself when on the mesh, else the nearest mesh point moved 2 mm inside.

        "Inside" means into the triangle owning the nearest boundary edge
        (toward its centroid), so the result is always on the mesh and so at
        least ``clearance`` from every obstacle. Ties go to the lowest edge.
        """
        q, _ = self._snap(_as_point(p, "point"))
        return float(q[0]), float(q[1])

    def same_component(self, a: object, b: object) -> bool:
        """Whether a path exists between ``a`` and ``b`` (after snapping both)."""
        _, ta = self._snap(_as_point(a, "a"))
        _, tb = self._snap(_as_point(b, "b"))
        return bool(self.components[ta] == self.components[tb])

    def find_path(self, start: object, goal: object) -> np.ndarray:
        """Waypoints ``(K, 2)``, ``K >= 2``, from ``start`` to ``goal``.

        Start and goal are first snapped onto the mesh (see
        :meth:`nearest_walkable`); the path begins at the snapped start and
        ends at the snapped goal, and its interior waypoints are the corners it
        turns around. Every segment stays on the mesh, so at least
        ``clearance`` from every obstacle. The corridor comes from A* over
        triangles (see :func:`pedvr.world.pathing.astar_corridor`), the path
        from the funnel through its portals. Deterministic.

        Raises :class:`NavigationError` naming both points when they lie in
        different connected parts of the mesh, or when either is not finite.
        """
        s0 = _as_point(start, "start")
        g0 = _as_point(goal, "goal")
        s, ts = self._snap(s0)
        g, tg = self._snap(g0)
        if self.components[ts] != self.components[tg]:
            raise NavigationError(
                f"no path from {_fmt(s0)} to {_fmt(g0)}: they lie in separate parts of the "
                f"walkable area for clearance {self.clearance} m"
            )
        if ts == tg:
            return np.array([s, g])
        best: np.ndarray | None = None
        best_len = np.inf
        # The corridor search is greedy about where it crosses each portal, and
        # its mistakes differ by direction: search both ways, keep the shorter.
        for a, b, ta, tb, flip in ((s, g, ts, tg, False), (g, s, tg, ts, True)):
            corridor = astar_corridor(
                self.verts, self.tris, self.neighbors, ta, tb, (a[0], a[1]), (b[0], b[1]),
                cost=self._cost,
            )
            if corridor is None:  # pragma: no cover - components say it is reachable
                raise NavigationError(f"no path from {_fmt(s0)} to {_fmt(g0)}")
            if flip:
                corridor = corridor[::-1]
            left, right = corridor_portals(self.verts, self.tris, self.neighbors, corridor)
            path = funnel(s, g, left, right)
            length = path_length(path)
            if length < best_len - 1e-12:
                best, best_len = path, length
        assert best is not None
        return best

    # -- sampling ----------------------------------------------------------

    def _region_triangles(self, region: BaseGeometry) -> tuple[np.ndarray, np.ndarray]:
        key = shapely.to_wkb(region)
        hit = self._region_cache.get(key)
        if hit is not None:
            return hit
        inter = shapely.intersection(self.polygon, region)
        polys = [g for g in shapely.get_parts(inter) if isinstance(g, Polygon) and g.area > 0.0]
        if not polys:
            b = region.bounds
            raise NavigationError(
                f"region with bounds ({b[0]:.3f}, {b[1]:.3f}, {b[2]:.3f}, {b[3]:.3f}) has no "
                f"walkable area for clearance {self.clearance} m"
            )
        verts, tris = _triangulate(polys[0] if len(polys) == 1 else MultiPolygon(polys))
        corners = verts[tris]  # (T, 3, 2)
        if len(self._region_cache) >= _REGION_CACHE_SIZE:
            self._region_cache.pop(next(iter(self._region_cache)))
        self._region_cache[key] = (corners, _cum_area(corners))
        return self._region_cache[key]

    def random_point(
        self, rng: np.random.Generator, region: BaseGeometry | None = None
    ) -> tuple[float, float]:
        """A point drawn uniformly over the mesh, or over its part inside ``region``.

        Picks a triangle with probability proportional to its area, then a
        uniform point in it; draws exactly three numbers from ``rng``.
        ``region`` is a shapely polygonal geometry; raises
        :class:`NavigationError` when it has no walkable area.
        """
        if region is None:
            corners = self.verts[self.tris]
            cum = _cum_area(corners)
        else:
            corners, cum = self._region_triangles(region)
        u, r1, r2 = rng.random(3)
        t = min(int(np.searchsorted(cum, u * cum[-1], side="right")), len(cum) - 1)
        if r1 + r2 > 1.0:  # fold the far half of the parallelogram back
            r1, r2 = 1.0 - r1, 1.0 - r2
        a, b, c = corners[t]
        p = a + r1 * (b - a) + r2 * (c - a)
        return float(p[0]), float(p[1])


def _cum_area(corners: np.ndarray) -> np.ndarray:
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    return np.cumsum(area)
