"""Line of sight and ray casts against the walkable area's outline.

The kernels live in :mod:`pedvr.world.visibility_kernels` (re-exported here);
:class:`Visibility` holds a world's edge arrays and validates inputs before
calling them. Edges are the unshrunk walkable-area boundary (obstacles and
the border), so a clearance is passed explicitly as a radius.
"""

from __future__ import annotations

import numpy as np

from pedvr.scene.config import WorldConfig
from pedvr.world.geometry import edges
from pedvr.world.visibility_kernels import (
    EdgeGrid,
    furthest_visible,
    raycast,
    segment_clear,
    visible_batch,
    visible_batch_grid,
)

__all__ = ["EdgeGrid", "Visibility", "furthest_visible", "raycast", "segment_clear", "visible_batch",
           "visible_batch_grid"]


def _points(x: object, name: str) -> np.ndarray:
    a = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"{name} has shape {a.shape}: must be (N, 2)")
    return a


def _vec(x: object, n: int, name: str, dtype: type) -> np.ndarray:
    """``x`` (a scalar or ``(n,)``) as a new writable ``(n,)`` array. Always a copy: a scalar
    broadcast to one row is already contiguous, and ``ascontiguousarray`` handed the read-only
    view on, which numba compiles as a second specialisation of the kernel (issue 27: a run's
    first one-row query compiled it mid-run)."""
    return np.array(np.broadcast_to(np.asarray(x, dtype=dtype), (n,)), dtype=dtype, order="C")


class Visibility:
    """Segment and ray queries against the edges of ``world``'s walkable area.

    ``p1``, ``p2`` are the ``(M, 2)`` edge endpoints (see
    :func:`pedvr.world.geometry.edges`), ``grid`` an :class:`EdgeGrid` of
    them for the batch queries. Distances and radii are metres.
    """

    def __init__(self, world: WorldConfig) -> None:
        self.p1, self.p2 = edges(world)
        self.grid = EdgeGrid.build(self.p1, self.p2)

    def segment_clear(self, a: object, b: object, radius: float = 0.0) -> bool:
        """Whether segment a–b stays more than ``radius`` from every edge."""
        (ax, ay), (bx, by) = np.asarray(a, np.float64), np.asarray(b, np.float64)
        return bool(segment_clear(ax, ay, bx, by, float(radius), self.p1, self.p2))

    def visible(self, a: object, b: object, radius: object = 0.0) -> np.ndarray:
        """``(N,)`` bool: :meth:`segment_clear` for each row of ``a``, ``b`` ``(N, 2)``.

        ``radius`` is a scalar or ``(N,)``.
        """
        aa, bb = _points(a, "a"), _points(b, "b")
        if aa.shape != bb.shape:
            raise ValueError(f"a has shape {aa.shape} and b {bb.shape}: must match")
        out = np.empty(aa.shape[0], np.bool_)
        visible_batch_grid(aa, bb, _vec(radius, aa.shape[0], "radius", np.float64), self.p1, self.p2,
                           *self.grid, out)
        return out

    def raycast(self, origin: object, direction: object, max_dist: float) -> float:
        """Distance from ``origin`` along ``direction`` to the first edge, at most ``max_dist``.

        ``direction`` need not be unit length (it is normalised here); a zero
        direction raises ValueError.
        """
        ox, oy = np.asarray(origin, np.float64)
        d = np.asarray(direction, np.float64)
        norm = float(np.hypot(d[0], d[1]))
        if not norm > 0.0:
            raise ValueError(f"direction = {direction!r}: must be non-zero")
        return float(raycast(ox, oy, d[0] / norm, d[1] / norm, float(max_dist), self.p1, self.p2))

    def furthest_visible(
        self,
        pos: object,
        radius: object,
        path_pts: object,
        path_start: object,
        path_len: object,
        cursor: object,
        *,
        lookahead: int,
    ) -> np.ndarray:
        """New waypoint cursors ``(N,) int64``; see :func:`furthest_visible` (the kernel).

        Raises ValueError when a path slice falls outside ``path_pts``.
        """
        p = _points(pos, "pos")
        n = p.shape[0]
        pts = _points(path_pts, "path_pts")
        start = _vec(path_start, n, "path_start", np.int64)
        length = _vec(path_len, n, "path_len", np.int64)
        cur = _vec(cursor, n, "cursor", np.int64)
        if np.any(length < 0) or np.any((length > 0) & ((start < 0) | (start + length > len(pts)))):
            raise ValueError("path_start/path_len: every path slice must lie inside path_pts")
        if lookahead < 0:
            raise ValueError(f"lookahead = {lookahead}: must be >= 0")
        out = np.empty(n, np.int64)
        furthest_visible(p, _vec(radius, n, "radius", np.float64), pts, start, length, cur,
                         int(lookahead), self.p1, self.p2, *self.grid, out)
        return out
