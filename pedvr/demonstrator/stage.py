"""What placement planning sees of the world and of the demonstrator's body.

:class:`Stage` holds the static obstacles as prisms (footprint polygon,
height, how much they hide) and the navigation mesh the demonstrator walks
on; :class:`Figure` the few body measures PLACE needs (disc radius, eye
height, right shoulder and arm length). Both are immutable and built once;
queries are vectorised over candidates (:mod:`pedvr.demonstrator.kernels`).

3D points follow the body layer's convention: a ground point ``(x, y)`` at
height ``h`` is ``(x, h, y)`` (:mod:`pedvr.body`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pedvr.body import rest_positions
from pedvr.body import skeleton as sk
from pedvr.demonstrator import kernels as kn
from pedvr.scene.config import WorldConfig
from pedvr.world.navmesh import NavMesh

SPHERE_SPACING = 0.08  # m between the spheres that stand for nearby obstacle surfaces (§6)


class Stage:
    """The static world for placement planning: obstacle prisms and the walkable mesh.

    ``mesh`` is the navigation mesh of the demonstrator's clearance (a
    candidate on it does not collide with any obstacle, and one in the
    demonstrator's connected part is reachable by a path with that clearance,
    §5's accessibility query). Obstacle arrays: ``verts (V, 2)``, ``starts
    (P+1,)``, ``height (P,)`` m, ``occlusion (P,)`` in (0, 1], ``bbox (P, 4)``.
    """

    def __init__(self, world: WorldConfig, mesh: NavMesh) -> None:
        self.world = world
        self.mesh = mesh
        obs = world.obstacles
        polys = [np.asarray(o.vertices, np.float64).reshape(-1, 2) for o in obs]
        self.verts = np.ascontiguousarray(np.concatenate(polys) if polys else np.zeros((0, 2)))
        self.starts = np.concatenate([[0], np.cumsum([len(p) for p in polys])]).astype(np.int64)
        self.height = np.asarray([o.height for o in obs], np.float64)
        self.occlusion = np.asarray([o.occlusion for o in obs], np.float64)
        self.bbox = np.asarray([[p[:, 0].min(), p[:, 1].min(), p[:, 0].max(), p[:, 1].max()] for p in polys],
                               np.float64).reshape(-1, 4)
        self.kinds = tuple(o.kind for o in obs)

    def __len__(self) -> int:
        return int(self.height.shape[0])

    def polygon(self, i: int) -> np.ndarray:
        return self.verts[self.starts[i]:self.starts[i + 1]]

    # -- the target's frame -------------------------------------------------------------------

    def support(self, p: tuple[float, float]) -> int | None:
        """The obstacle whose footprint contains ground point ``p`` (the table a target stands on)."""
        for i in range(len(self)):
            x0, y0, x1, y1 = self.bbox[i]
            if x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and _in_polygon(p, self.polygon(i)):
                return i
        return None

    def z_axis(self, p: tuple[float, float], default: float) -> float:
        """The heading (rad) of the model's Z axis for a target at ``p`` (§4).

        Orthogonal to the edge of the supporting obstacle closest to ``p``,
        pointing out of the obstacle through that edge; ``default`` when ``p``
        is not on an obstacle.
        """
        i = self.support(p)
        if i is None:
            return default
        poly = self.polygon(i)
        a, b = poly, np.roll(poly, -1, axis=0)
        d = b - a
        ll = np.maximum((d * d).sum(axis=1), 1e-18)
        t = np.clip(((np.asarray(p) - a) * d).sum(axis=1) / ll, 0.0, 1.0)
        q = a + t[:, None] * d
        k = int(np.argmin(np.hypot(*(q - np.asarray(p)).T)))
        # Counter-clockwise polygon: the outward normal of edge a->b is (dy, -dx).
        return math.atan2(-float(d[k, 0]), float(d[k, 1]))

    # -- queries over candidates ----------------------------------------------------------------

    def occluded(self, a: np.ndarray, ha: np.ndarray | float, b: np.ndarray,
                 hb: np.ndarray | float) -> np.ndarray:
        """``e_vis (M,)``: how much of the sight line a→b (ground points, heights) obstacles hide."""
        a = np.ascontiguousarray(a, np.float64).reshape(-1, 2)
        b = np.ascontiguousarray(b, np.float64).reshape(-1, 2)
        m = a.shape[0]
        out = np.empty(m)
        kn.occlusion_kernel(a, np.ascontiguousarray(np.broadcast_to(ha, (m,)), np.float64), b,
                            np.ascontiguousarray(np.broadcast_to(hb, (m,)), np.float64), self.verts,
                            self.starts, self.height, self.occlusion, self.bbox, out)
        return out

    def inside(self, p3: np.ndarray) -> np.ndarray:
        """``(M,)`` bool: 3D points ``(x, h, y)`` inside an obstacle prism."""
        p3 = np.asarray(p3, np.float64).reshape(-1, 3)
        out = np.empty(p3.shape[0], np.bool_)
        kn.inside_kernel(np.ascontiguousarray(p3[:, [0, 2]]), np.ascontiguousarray(p3[:, 1]), self.verts,
                         self.starts, self.height, self.bbox, out)
        return out

    def spheres(self, center: np.ndarray, reach: float) -> np.ndarray:
        """Small spheres ``(S, 4)`` (x, h, y, r) covering obstacle surfaces within ``reach`` of ``center``.

        §6 approximates "the bounding volume of the nearby obstacles with
        small spheres S_i". Here: the tops and sides of the prisms, sampled
        every :data:`SPHERE_SPACING` m, each sphere of radius 0.75 × that
        spacing so neighbours overlap and the surface has no gaps a hand could
        pass through; only those within ``reach`` m of ``center`` (3D).
        """
        c = np.asarray(center, np.float64).reshape(3)
        s = SPHERE_SPACING
        out: list[np.ndarray] = []
        for i in range(len(self)):
            x0, y0, x1, y1 = self.bbox[i]
            if x1 < c[0] - reach or x0 > c[0] + reach or y1 < c[2] - reach or y0 > c[2] + reach:
                continue
            poly = self.polygon(i)
            h = float(self.height[i])
            # top face: a grid clipped to the footprint
            xs = np.arange(x0 + s / 2, x1, s)
            ys = np.arange(y0 + s / 2, y1, s)
            gx, gy = np.meshgrid(xs, ys, indexing="ij")
            g = np.stack([gx.ravel(), gy.ravel()], 1)
            g = g[np.hypot(g[:, 0] - c[0], g[:, 1] - c[2]) <= reach]
            if g.size:
                keep = np.empty(len(g), np.bool_)
                kn.in_polygon_kernel(np.ascontiguousarray(g), self.verts, self.starts[i], self.starts[i + 1],
                                     keep)
                g = g[keep]
                out.append(np.column_stack([g[:, 0], np.full(len(g), h - s / 2), g[:, 1]]))
            # sides: along each edge, at heights below the top
            hs = np.arange(h - s / 2, 0.0, -s)
            a, b = poly, np.roll(poly, -1, axis=0)
            for e in range(len(poly)):
                length = float(np.hypot(*(b[e] - a[e])))
                ts = (np.arange(0.0, length, s) + s / 2) / max(length, 1e-9)
                pts = a[e] + np.clip(ts, 0, 1)[:, None] * (b[e] - a[e])
                near = np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[2]) <= reach
                pts = pts[near]
                if pts.size == 0 or hs.size == 0:
                    continue
                px = np.repeat(pts[:, 0], hs.size)
                py = np.repeat(pts[:, 1], hs.size)
                out.append(np.column_stack([px, np.tile(hs, len(pts)), py]))
        if not out:
            return np.zeros((0, 4))
        ctr = np.concatenate(out)
        ctr = ctr[np.linalg.norm(ctr - c, axis=1) <= reach + s]
        return np.column_stack([ctr, np.full(len(ctr), 0.75 * s)])


def _in_polygon(p: tuple[float, float], poly: np.ndarray) -> bool:
    x, y = p
    inside = False
    n = len(poly)
    j = n - 1
    for i in range(n):
        xi, yi = poly[i]
        xj, yj = poly[j]
        if (yi > y) != (yj > y) and x < xj + (y - yj) * (xi - xj) / (yi - yj):
            inside = not inside
        j = i
    return inside


@dataclass(frozen=True)
class Figure:
    """The demonstrator's body as PLACE uses it: body frame +X left, +Y up, +Z forward (:mod:`pedvr.body`).

    ``shoulder``/``hand_rest`` are the right shoulder and the right hand
    joint standing at rest, ``arm`` the shoulder–hand length (what the arm IK
    can reach), ``eye_height`` the eyes' height, ``radius`` the disc.
    """

    radius: float
    eye_height: float
    shoulder: tuple[float, float, float]
    hand_rest: tuple[float, float, float]
    arm: float

    @classmethod
    def of_dims(cls, dims: np.ndarray, radius: float) -> Figure:
        """From body dims ``(4,)`` (:mod:`pedvr.body.skeleton`)."""
        rp = rest_positions(np.asarray(dims, np.float64).reshape(1, 4))[0]
        sh = rp[sk.R_SHOULDER]
        hand = rp[sk.R_HAND]
        eye = 0.5 * (rp[sk.L_EYE] + rp[sk.R_EYE])
        return cls(radius=float(radius), eye_height=float(eye[1]), shoulder=(float(sh[0]), float(sh[1]),
                   float(sh[2])), hand_rest=(float(hand[0]), float(hand[1]), float(hand[2])),
                   arm=float(np.linalg.norm(hand - sh)))

    def world(self, pos: np.ndarray, heading: np.ndarray, local: tuple[float, float, float]) -> np.ndarray:
        """Body-frame point ``local`` for bodies at ``pos (M, 2)`` facing ``heading (M,)``: ``(M, 3)``."""
        pos = np.asarray(pos, np.float64).reshape(-1, 2)
        h = np.asarray(heading, np.float64).reshape(-1)
        lx, ly, lz = local
        # forward (cos h, sin h); the body's left is heading - 90 deg: (sin h, -cos h)
        x = pos[:, 0] + lz * np.cos(h) + lx * np.sin(h)
        y = pos[:, 1] + lz * np.sin(h) - lx * np.cos(h)
        return np.column_stack([x, np.full(len(h), ly), y])
