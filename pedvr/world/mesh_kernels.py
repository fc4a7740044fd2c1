"""numba kernels over the navigation mesh's triangle arrays.

Triangles are ``tris (T, 3) int64`` indices into ``verts (V, 2) float64``,
counter-clockwise. Point location uses a uniform grid over the triangles'
bounding boxes, stored CSR-style: the triangles overlapping cell ``c`` are
``cell_tris[cell_start[c]:cell_start[c + 1]]``, in ascending index, so a point
on an edge shared by two triangles always resolves to the lower index.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from pedvr.kernels import parallel_kernel

# A point this far (metres) outside a triangle still counts as inside it, so
# that points on shared edges and on the boundary are never lost to rounding.
INSIDE_TOL = 1e-9


@njit(cache=True)
def _cell_range(lo: float, hi: float, origin: float, inv_h: float, n: int) -> tuple[int, int]:
    i0 = int(np.floor((lo - origin) * inv_h))
    i1 = int(np.floor((hi - origin) * inv_h))
    return max(i0, 0), min(i1, n - 1)


@njit(cache=True)
def _tri_cells(
    verts: np.ndarray, tris: np.ndarray, t: int, origin: np.ndarray, inv_h: float, nx: int, ny: int
) -> tuple[int, int, int, int]:
    a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
    x0 = min(verts[a, 0], verts[b, 0], verts[c, 0]) - INSIDE_TOL
    x1 = max(verts[a, 0], verts[b, 0], verts[c, 0]) + INSIDE_TOL
    y0 = min(verts[a, 1], verts[b, 1], verts[c, 1]) - INSIDE_TOL
    y1 = max(verts[a, 1], verts[b, 1], verts[c, 1]) + INSIDE_TOL
    ix0, ix1 = _cell_range(x0, x1, origin[0], inv_h, nx)
    iy0, iy1 = _cell_range(y0, y1, origin[1], inv_h, ny)
    return ix0, ix1, iy0, iy1


@njit(cache=True)
def build_grid(
    verts: np.ndarray, tris: np.ndarray, origin: np.ndarray, h: float, nx: int, ny: int
) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the triangles whose (slightly padded) bbox overlaps each cell.

    Returns ``(cell_start (nx*ny + 1,), cell_tris)``; cell ``(ix, iy)`` is
    ``iy * nx + ix``. Build time only: allocates.
    """
    inv_h = 1.0 / h
    cell_start = np.zeros(nx * ny + 1, np.int64)
    for t in range(tris.shape[0]):
        ix0, ix1, iy0, iy1 = _tri_cells(verts, tris, t, origin, inv_h, nx, ny)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                cell_start[iy * nx + ix + 1] += 1
    for c in range(nx * ny):
        cell_start[c + 1] += cell_start[c]
    cell_tris = np.empty(cell_start[nx * ny], np.int64)
    fill = cell_start[:-1].copy()
    for t in range(tris.shape[0]):
        ix0, ix1, iy0, iy1 = _tri_cells(verts, tris, t, origin, inv_h, nx, ny)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                c = iy * nx + ix
                cell_tris[fill[c]] = t
                fill[c] += 1
    return cell_start, cell_tris


@njit(cache=True)
def _inside(verts: np.ndarray, tris: np.ndarray, t: int, x: float, y: float) -> bool:
    # Left of (or within INSIDE_TOL of) all three CCW edges.
    for k in range(3):
        a = tris[t, k]
        b = tris[t, (k + 1) % 3]
        ex = verts[b, 0] - verts[a, 0]
        ey = verts[b, 1] - verts[a, 1]
        cross = ex * (y - verts[a, 1]) - ey * (x - verts[a, 0])
        if cross < -INSIDE_TOL * np.sqrt(ex * ex + ey * ey):
            return False
    return True


@parallel_kernel()
def locate_points(
    points: np.ndarray,
    verts: np.ndarray,
    tris: np.ndarray,
    origin: np.ndarray,
    h: float,
    nx: int,
    ny: int,
    cell_start: np.ndarray,
    cell_tris: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[i]`` = lowest index of a triangle containing ``points[i]``, or -1."""
    inv_h = 1.0 / h
    for i in prange(points.shape[0]):
        x = points[i, 0]
        y = points[i, 1]
        out[i] = -1
        fx = (x - origin[0]) * inv_h
        fy = (y - origin[1]) * inv_h
        if not (fx >= 0.0 and fy >= 0.0 and fx < nx and fy < ny):  # also rejects NaN
            continue
        c = int(fy) * nx + int(fx)
        for j in range(cell_start[c], cell_start[c + 1]):
            t = cell_tris[j]
            if _inside(verts, tris, t, x, y):
                out[i] = t
                break


@njit(cache=True)
def nearest_on_edges(x: float, y: float, a: np.ndarray, b: np.ndarray) -> tuple[int, float, float]:
    """The closest point to ``(x, y)`` on segments ``a[k]``–``b[k]``.

    Returns ``(k, qx, qy)`` for the nearest segment (lowest ``k`` on ties),
    or ``(-1, x, y)`` when there are no segments.
    """
    best = np.inf
    best_k = -1
    qx = x
    qy = y
    for k in range(a.shape[0]):
        dx = b[k, 0] - a[k, 0]
        dy = b[k, 1] - a[k, 1]
        ll = dx * dx + dy * dy
        s = 0.0
        if ll > 0.0:
            s = ((x - a[k, 0]) * dx + (y - a[k, 1]) * dy) / ll
            s = min(max(s, 0.0), 1.0)
        px = a[k, 0] + s * dx
        py = a[k, 1] + s * dy
        d = (px - x) * (px - x) + (py - y) * (py - y)
        if d < best:
            best = d
            best_k = k
            qx = px
            qy = py
    return best_k, qx, qy
