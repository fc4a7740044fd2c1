"""Static obstacles in the layout RVO2 uses, for the ORCA kernels.

Each polygon is a closed chain of vertices. Following RVO2, an obstacle's
vertices run counter-clockwise; a boundary that encloses the agents (the
walkable area's outer ring) runs clockwise. Vertex ``k`` carries the edge from
``vertices[k]`` to ``vertices[next[k]]``, whose unit direction is
``direction[k]``; ``convex[k]`` says whether the chain turns left at ``k``.
A polygon with two vertices is a line segment, as in RVO2.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ObstacleSet:
    vertices: np.ndarray  # (M, 2) float64, m
    next: np.ndarray  # (M,) int64: index of the next vertex of the same polygon
    prev: np.ndarray  # (M,) int64
    direction: np.ndarray  # (M, 2) float64, unit vector of the edge k -> next[k]
    convex: np.ndarray  # (M,) bool

    @classmethod
    def empty(cls) -> ObstacleSet:
        return cls(np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64),
                   np.zeros((0, 2)), np.zeros(0, np.bool_))

    @classmethod
    def from_polygons(cls, polygons: Sequence[np.ndarray | Sequence[tuple[float, float]]]) -> ObstacleSet:
        """Build from polygons already in RVO2 orientation (see module doc).

        Mirrors ``RVOSimulator::addObstacle``: a vertex is convex when the
        chain turns left (or goes straight) there.
        """
        verts: list[np.ndarray] = []
        nxt: list[int] = []
        prv: list[int] = []
        for poly in polygons:
            p = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
            if p.shape[0] < 2:
                raise ValueError("an obstacle needs at least two vertices")
            base = sum(v.shape[0] for v in verts)
            n = p.shape[0]
            verts.append(p)
            for k in range(n):
                nxt.append(base + (k + 1) % n)
                prv.append(base + (k - 1) % n)
        if not verts:
            return cls.empty()
        v = np.ascontiguousarray(np.concatenate(verts))
        nx = np.asarray(nxt, np.int64)
        pv = np.asarray(prv, np.int64)
        d = v[nx] - v
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        a, b, c = v[pv], v, v[nx]
        # leftOf(prev, cur, next) >= 0, and two-vertex chains are convex.
        left = (a[:, 0] - c[:, 0]) * (b[:, 1] - a[:, 1]) - (a[:, 1] - c[:, 1]) * (b[:, 0] - a[:, 0])
        convex = left >= 0.0
        two = nx == pv
        convex[two] = True
        return cls(v, nx, pv, np.ascontiguousarray(d), convex)

    def __len__(self) -> int:
        return int(self.vertices.shape[0])

    def segments(self) -> tuple[np.ndarray, np.ndarray]:
        """Every edge as ``(p1, p2)`` arrays of shape (M, 2)."""
        return self.vertices, self.vertices[self.next]
