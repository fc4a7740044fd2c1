"""numba kernels of the placement planner: sight lines through obstacle volumes, points inside them.

Obstacles are prisms: a simple polygon on the ground (``verts[starts[i]:starts[i+1]]``)
extruded from the floor to ``height[i]``; ``occl[i]`` in (0, 1] is how much of
what lies behind it an obstacle hides (1 a wall, 0.5 the paper's house plant,
§4). ``bbox[i]`` is ``(xmin, ymin, xmax, ymax)``. Ground points are ``(x, y)``
with a separate height (m); nothing here allocates in its loops.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def _inside(px, py, verts, s, e):  # type: ignore[no-untyped-def]
    """Ray-crossing point-in-polygon test of ``(px, py)`` against ``verts[s:e]``."""
    inside = False
    j = e - 1
    for i in range(s, e):
        xi, yi = verts[i, 0], verts[i, 1]
        xj, yj = verts[j, 0], verts[j, 1]
        if (yi > py) != (yj > py):
            x = xj + (py - yj) * (xi - xj) / (yi - yj)
            if px < x:
                inside = not inside
        j = i
    return inside


@njit(cache=True)
def occlusion_kernel(a, ha, b, hb, verts, starts, height, occl, bbox, out):  # type: ignore[no-untyped-def]
    """How much of the sight line from ``a`` (at height ``ha``) to ``b`` (``hb``) is hidden, ``out (M,)``.

    A prism hides the line where the line crosses its footprint below its top:
    the line's lowest point over the stretch it spends inside the footprint
    (entry to exit, the line being straight) is compared with the prism's
    height (the 3D check against object heights, §4). Several occluders
    combine as independent filters: ``e_vis = 1 − Π (1 − occl_i)``.
    """
    m = a.shape[0]
    p = height.shape[0]
    for k in range(m):
        ax, ay, bx, by = a[k, 0], a[k, 1], b[k, 0], b[k, 1]
        dx, dy = bx - ax, by - ay
        lo_x, hi_x = min(ax, bx), max(ax, bx)
        lo_y, hi_y = min(ay, by), max(ay, by)
        seen = 1.0
        for i in range(p):
            if bbox[i, 2] < lo_x or bbox[i, 0] > hi_x or bbox[i, 3] < lo_y or bbox[i, 1] > hi_y:
                continue
            s, e = starts[i], starts[i + 1]
            t_in = 2.0
            t_out = -1.0
            if _inside(ax, ay, verts, s, e):
                t_in = 0.0
                t_out = 0.0
            if _inside(bx, by, verts, s, e):
                t_in = min(t_in, 1.0)
                t_out = 1.0
            j = e - 1
            for q in range(s, e):
                # Crossing of segment a-b with edge verts[j]-verts[q].
                ex, ey = verts[q, 0] - verts[j, 0], verts[q, 1] - verts[j, 1]
                den = dx * ey - dy * ex
                if abs(den) > 1e-15:
                    wx, wy = verts[j, 0] - ax, verts[j, 1] - ay
                    t = (wx * ey - wy * ex) / den
                    u = (wx * dy - wy * dx) / den
                    if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
                        t_in = min(t_in, t)
                        t_out = max(t_out, t)
                j = q
            if t_out < 0.0:
                continue
            h_in = ha[k] + (hb[k] - ha[k]) * t_in
            h_out = ha[k] + (hb[k] - ha[k]) * t_out
            if min(h_in, h_out) < height[i]:
                seen *= 1.0 - occl[i]
        out[k] = 1.0 - seen


@njit(cache=True)
def inside_kernel(p, h, verts, starts, height, bbox, out):  # type: ignore[no-untyped-def]
    """``out[k]``: ground point ``p[k]`` at height ``h[k]`` lies inside an obstacle prism."""
    m = p.shape[0]
    n = height.shape[0]
    for k in range(m):
        px, py = p[k, 0], p[k, 1]
        hit = False
        for i in range(n):
            if h[k] >= height[i] or h[k] < 0.0:
                continue
            if px < bbox[i, 0] or px > bbox[i, 2] or py < bbox[i, 1] or py > bbox[i, 3]:
                continue
            if _inside(px, py, verts, starts[i], starts[i + 1]):
                hit = True
                break
        out[k] = hit


@njit(cache=True)
def segment_distance_kernel(a, b, p, out):  # type: ignore[no-untyped-def]
    """``out[k]``: distance from ground point ``p[k]`` to segment ``a[k]``–``b[k]`` (m)."""
    for k in range(p.shape[0]):
        dx, dy = b[k, 0] - a[k, 0], b[k, 1] - a[k, 1]
        wx, wy = p[k, 0] - a[k, 0], p[k, 1] - a[k, 1]
        ll = dx * dx + dy * dy
        t = 0.0 if ll < 1e-18 else min(max((wx * dx + wy * dy) / ll, 0.0), 1.0)
        out[k] = math.hypot(wx - t * dx, wy - t * dy)


@njit(cache=True)
def in_polygon_kernel(p, verts, s, e, out):  # type: ignore[no-untyped-def]
    """``out[k]``: ground point ``p[k]`` lies inside the polygon ``verts[s:e]``."""
    for k in range(p.shape[0]):
        out[k] = _inside(p[k, 0], p[k, 1], verts, s, e)


@njit(cache=True)
def _clearance(ex, ey, ez, spheres):  # type: ignore[no-untyped-def]
    best = math.inf
    for i in range(spheres.shape[0]):
        d = math.sqrt((ex - spheres[i, 0]) ** 2 + (ey - spheres[i, 1]) ** 2 + (ez - spheres[i, 2]) ** 2)
        best = min(best, d - spheres[i, 3])
    return best


@njit(cache=True)
def avoid_kernel(path, spheres, clearance, near, step, max_steps, window):  # type: ignore[no-untyped-def]
    """§6's single pass over the end effector's frames ``path (K, 3)``, in place; returns how many
    frames were moved.

    A frame closer than ``clearance`` to a sphere's surface descends the collision potential
    ``P_c = exp(−Σ distance(E, S_i))`` over the spheres within ``near``: ``−∇P_c`` points along
    ``Σ (E − c_i)/|E − c_i|``, so the frame takes steps of ``step`` m that way until it is clear (at
    most ``max_steps``); its correction is spread over ``window`` frames on each side with linearly
    falling weights. The first and last frames are never moved.
    """
    n = path.shape[0]
    moved = 0
    for j in range(1, n - 1):
        ex, ey, ez = path[j, 0], path[j, 1], path[j, 2]
        went = False
        for _ in range(max_steps):
            if _clearance(ex, ey, ez, spheres) >= clearance:
                break
            gx = gy = gz = 0.0
            for i in range(spheres.shape[0]):
                dx, dy, dz = ex - spheres[i, 0], ey - spheres[i, 1], ez - spheres[i, 2]
                d = math.sqrt(dx * dx + dy * dy + dz * dz)
                if d <= near and d > 1e-9:
                    gx += dx / d
                    gy += dy / d
                    gz += dz / d
            g = math.sqrt(gx * gx + gy * gy + gz * gz)
            if g < 1e-9:
                gx, gy, gz, g = 0.0, 1.0, 0.0, 1.0
            ex += step * gx / g
            ey += step * gy / g
            ez += step * gz / g
            went = True
        if went:
            moved += 1
            dx, dy, dz = ex - path[j, 0], ey - path[j, 1], ez - path[j, 2]
            path[j, 0], path[j, 1], path[j, 2] = ex, ey, ez
            for m in range(1, window):
                w = 1.0 - m / window
                for q in (j - m, j + m):
                    if 0 < q < n - 1:
                        path[q, 0] += w * dx
                        path[q, 1] += w * dy
                        path[q, 2] += w * dz
    return moved
