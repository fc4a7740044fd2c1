"""The walkable area of a world and its outline, as polygons and segment arrays.

The walkable area is the ``bounds`` rectangle minus the union of all
obstacles; obstacles may overlap each other and the border, and the union
merges them into one outline. Everything here is plain geometry: no agent
radius is applied (the navigation mesh shrinks the area by its clearance).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.polygon import orient

from pedvr.errors import NavigationError
from pedvr.scene.config import WorldConfig
from pedvr.world.obstacles import ObstacleSet


def _obstacle_polygon(index: int, vertices: tuple[tuple[float, float], ...]) -> Polygon:
    poly = Polygon(vertices) if len(vertices) >= 3 else Polygon()
    if poly.is_empty or not poly.is_valid or poly.area <= 0.0:
        raise NavigationError(
            f"world.obstacles[{index}] = {list(vertices)}: must be a simple polygon "
            "with at least 3 vertices and positive area"
        )
    return poly


def walkable_area(world: WorldConfig) -> Polygon | MultiPolygon:
    """The bounds box minus the union of the obstacles (metres).

    Returns a normalized Polygon or MultiPolygon (GEOS ``normalize``: a fixed
    vertex order, so the same world always gives the same rings). It may be
    empty when obstacles cover everything. Raises :class:`NavigationError`
    naming the obstacle when one is not a simple polygon of positive area,
    or when the bounds are empty.
    """
    (xmin, ymin), (xmax, ymax) = world.bounds
    if not (xmax > xmin and ymax > ymin):
        raise NavigationError(f"world.bounds = {world.bounds}: must have xmax > xmin and ymax > ymin")
    room = shapely.box(xmin, ymin, xmax, ymax)
    polys = [_obstacle_polygon(i, o.vertices) for i, o in enumerate(world.obstacles)]
    area = room.difference(shapely.union_all(polys)) if polys else room
    # Drop collinear vertices left where obstacles touch the border or each other.
    area = shapely.normalize(shapely.simplify(area, 0.0))
    if isinstance(area, Polygon | MultiPolygon):
        return area
    # A difference can return a GeometryCollection with slivers of lower dimension.
    parts = [g for g in shapely.get_parts(area) if isinstance(g, Polygon) and g.area > 0.0]
    return shapely.normalize(MultiPolygon(parts)) if len(parts) != 1 else parts[0]


def polygons_of(area: Polygon | MultiPolygon) -> list[Polygon]:
    """The non-empty polygons of a Polygon or MultiPolygon, in stored order."""
    if area.is_empty:
        return []
    if isinstance(area, Polygon):
        return [area]
    return [p for p in area.geoms if not p.is_empty]


def rvo_rings(area: Polygon | MultiPolygon) -> list[np.ndarray]:
    """The rings of ``area`` in RVO2 orientation, without the closing vertex.

    Exterior rings run clockwise (they enclose the agents), interior rings
    (obstacles seen from the walkable side) counter-clockwise. Each is an
    ``(n, 2)`` float64 array.
    """
    rings: list[np.ndarray] = []
    for poly in polygons_of(area):
        # sign=-1: exterior clockwise, holes counter-clockwise.
        p = orient(poly, sign=-1.0)
        rings.append(np.asarray(p.exterior.coords, dtype=np.float64)[:-1])
        rings.extend(np.asarray(r.coords, dtype=np.float64)[:-1] for r in p.interiors)
    return rings


def obstacle_set(world: WorldConfig) -> ObstacleSet:
    """The walkable area's outline as an :class:`ObstacleSet` for ORCA.

    Overlapping obstacles (with each other or the border) become one outline,
    so ORCA never sees an edge buried inside another obstacle.
    """
    return ObstacleSet.from_polygons(rvo_rings(walkable_area(world)))


def edges(world: WorldConfig) -> tuple[np.ndarray, np.ndarray]:
    """Every boundary segment of the walkable area as ``(p1, p2)``.

    Both are C-contiguous ``(M, 2)`` float64 arrays (metres), in the same
    order and orientation as :func:`obstacle_set`; used by visibility tests
    and ray casts.
    """
    return segments_of(rvo_rings(walkable_area(world)))


def segments_of(rings: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Closed rings as segment arrays ``(p1, p2)``, each ``(M, 2)`` float64."""
    if not rings:
        return np.zeros((0, 2)), np.zeros((0, 2))
    p1 = np.concatenate(rings)
    p2 = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    return np.ascontiguousarray(p1), np.ascontiguousarray(p2)
