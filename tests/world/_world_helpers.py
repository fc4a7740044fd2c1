"""Shared builders and an independent shortest-path oracle for the world tests."""

from __future__ import annotations

import numpy as np
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from pedvr.scene.config import Obstacle, WorldConfig


def box_obstacle(x0: float, y0: float, x1: float, y1: float, kind: str = "box") -> Obstacle:
    return Obstacle(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), kind=kind)


def random_box_world(rng: np.random.Generator, n: int, size: float) -> WorldConfig:
    obs = []
    for _ in range(n):
        cx, cy = rng.uniform(1.0, size - 1.0, 2)
        w, h = rng.uniform(0.3, 0.1 * size, 2)
        obs.append(box_obstacle(cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2))
    return WorldConfig(((0.0, 0.0), (size, size)), tuple(obs))


def obstacles_geometry(world: WorldConfig) -> shapely.Geometry:
    """Everything that is not walkable: obstacles plus a thick frame around the bounds."""
    (x0, y0), (x1, y1) = world.bounds
    room = shapely.box(x0, y0, x1, y1)
    frame = shapely.box(x0 - 10, y0 - 10, x1 + 10, y1 + 10).difference(room)
    return shapely.union_all([frame] + [shapely.Polygon(o.vertices) for o in world.obstacles])


def path_length(path: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def visibility_graph_shortest(poly: shapely.Geometry, s: np.ndarray, g: np.ndarray) -> float:
    """Shortest s->g distance inside ``poly``: Dijkstra over its vertices.

    Independent of the navigation mesh: two nodes are joined when the segment
    between them lies in ``poly`` (grown by 1e-7 m to accept grazing).
    """
    pts = [np.asarray(s), np.asarray(g)]
    for part in shapely.get_parts(poly):
        for ring in [part.exterior, *part.interiors]:
            pts.extend(np.asarray(ring.coords)[:-1])
    p = np.array(pts)
    n = len(p)
    i, j = np.triu_indices(n, 1)
    lines = shapely.linestrings(np.stack([p[i], p[j]], axis=1))
    grown = poly.buffer(1e-7)
    shapely.prepare(grown)
    ok = shapely.covers(grown, lines)
    d = np.linalg.norm(p[i] - p[j], axis=1)
    m = csr_matrix((d[ok], (i[ok], j[ok])), shape=(n, n))
    return float(dijkstra(m, directed=False, indices=0)[1])
