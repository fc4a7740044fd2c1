"""Neighbour search for ORCA: a uniform grid over agents and one over obstacle edges.

RVO2 finds neighbours with a k-d tree rebuilt every step; here a uniform grid
does the same job with a counting sort (O(N), no pointer chasing, trivially
parallel queries).

Agents (:func:`build_agent_grid`, :func:`agent_neighbors`)
    Each agent gets the ``max_neighbors`` nearest *other* agents whose squared
    distance is below ``neighbor_dist**2``, sorted by distance. This is the set
    RVO2's ``KdTree::computeAgentNeighbors`` / ``Agent::insertAgentNeighbor``
    produces (strict ``<`` against a range that shrinks to the K-th distance
    once K are found), except that equal distances go by row (RVO2's follow its tree). The user
    row is an ordinary neighbour.

Obstacles (:func:`build_obstacle_grid`, :func:`obstacle_neighbors_of`)
    Edge ``k`` (from ``vertices[k]`` to ``vertices[next[k]]``) is a neighbour of
    an agent at ``p`` when ``p`` lies strictly on the edge's right (outside a
    counter-clockwise obstacle; RVO2 only "sees" an edge from that side) and
    the squared point–segment distance is below
    ``(time_horizon_obst * max_speed + radius)**2``. Neighbours are sorted by
    that distance, as RVO2's ``insertObstacleNeighbor`` does. Edges are filed
    in every grid cell their bounding box touches; a query visits the cells
    overlapping its range square and handles each edge once (in the first
    cell of the overlap of the two cell ranges), so no "seen" set is needed.

    Sharp edge: RVO2's obstacle tree splits edges that straddle a splitting
    line (``processObstacles``); we never split. Where RVO2 did split, its
    neighbour list holds two pieces where ours holds one edge, and where two
    edges are at exactly the same distance (an agent facing a convex corner)
    the tie order is ours (by edge index), not the tree's.

All kernels are pure functions over arrays (float64 positions, int64 indices).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from pedvr.kernels import parallel_kernel, row_njit

# Grids never have more cells than this many per agent (or per edge): keeps a
# few far-flung agents from allocating a huge, empty grid.
MAX_CELLS_PER_ITEM = 4.0
# ORCA's neighbour grid has at most this many cells per agent (two agents a cell on average): in a
# sparse crowd a third of the neighbour distance makes cells mostly empty, and the ring search pays
# for visiting them (issue 27: 1000 agents at 0.2 per m², the search took 0.48 ms a step in 1.67 m
# cells, 0.35 ms in 3.75 m ones; the same lists). Dense crowds keep the third.
NEIGHBOR_CELLS_PER_AGENT = 0.5


class AgentGrid(NamedTuple):
    """Agents counting-sorted into square cells (rebuilt every step).

    ``cell_start[c]:cell_start[c+1]`` index ``order``/``sorted_pos`` for cell
    ``c = cy * nx + cx``; ``origin`` is the lower-left corner, ``cell`` the
    side length in metres, ``shape`` is ``(nx, ny)``.
    """

    origin: np.ndarray  # (2,) float64
    cell: float
    shape: tuple[int, int]
    cell_start: np.ndarray  # (nx*ny+1,) int64
    order: np.ndarray  # (N,) int64, agent row of each sorted slot
    sorted_pos: np.ndarray  # (N, 2) float64, positions in sorted order


class ObstacleGrid(NamedTuple):
    """Obstacle edges filed by bounding box into square cells (static)."""

    origin: np.ndarray  # (2,) float64
    cell: float
    shape: tuple[int, int]
    cell_start: np.ndarray  # (nx*ny+1,) int64
    cell_edges: np.ndarray  # (total,) int64 edge (= first vertex) index
    edge_cells: np.ndarray  # (M, 4) int64: cx0, cy0, cx1, cy1 of the edge's bbox


@njit(cache=True)
def _grid_shape(minx, maxx, miny, maxy, cell_size, items, per_item):
    """Cell side and counts covering the box, grown until at most ~``per_item`` cells per item."""
    cell = cell_size
    max_cells = int(per_item * items) + 16
    while True:
        nx = int((maxx - minx) / cell) + 1
        ny = int((maxy - miny) / cell) + 1
        if nx * ny <= max_cells:
            return cell, nx, ny
        cell *= 1.5


@njit(cache=True)
def build_agent_grid_arrays(pos, cell_size, per_item):
    """Counting sort of ``pos (N,2)`` into cells of side ``>= cell_size``, grown (by 1.5×) until
    there are at most about ``per_item`` cells per agent.

    Returns ``(origin, cell, nx, ny, cell_start, order, sorted_pos)``. Stable:
    within a cell, agents keep their row order (deterministic).
    """
    n = pos.shape[0]
    origin = np.zeros(2)
    if n == 0:
        return (origin, cell_size, 1, 1, np.zeros(2, np.int64), np.zeros(0, np.int64),
                np.zeros((0, 2)))
    minx = pos[0, 0]
    maxx = pos[0, 0]
    miny = pos[0, 1]
    maxy = pos[0, 1]
    for i in range(1, n):
        x = pos[i, 0]
        y = pos[i, 1]
        minx = min(minx, x)
        maxx = max(maxx, x)
        miny = min(miny, y)
        maxy = max(maxy, y)
    cell, nx, ny = _grid_shape(minx, maxx, miny, maxy, cell_size, n, per_item)
    origin[0] = minx
    origin[1] = miny
    inv = 1.0 / cell
    ncell = nx * ny
    cell_of = np.empty(n, np.int64)
    cell_start = np.zeros(ncell + 1, np.int64)
    for i in range(n):
        cx = min(int((pos[i, 0] - minx) * inv), nx - 1)
        cy = min(int((pos[i, 1] - miny) * inv), ny - 1)
        c = cy * nx + cx
        cell_of[i] = c
        cell_start[c + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    order = np.empty(n, np.int64)
    sorted_pos = np.empty((n, 2))
    for i in range(n):
        c = cell_of[i]
        k = fill[c]
        fill[c] = k + 1
        order[k] = i
        sorted_pos[k, 0] = pos[i, 0]
        sorted_pos[k, 1] = pos[i, 1]
    return origin, cell, nx, ny, cell_start, order, sorted_pos


def build_agent_grid(pos: np.ndarray, cell_size: float, *,
                     per_item: float = MAX_CELLS_PER_ITEM) -> AgentGrid:
    """Grid over agent positions ``pos (N,2) float64``; cells of side ``>= cell_size``, at most
    about ``per_item`` cells per agent."""
    origin, cell, nx, ny, cs, order, spos = build_agent_grid_arrays(pos, float(cell_size), float(per_item))
    return AgentGrid(origin, float(cell), (int(nx), int(ny)), cs, order, spos)


@row_njit(inline="always")
def cell_span(px, py, reach, origin, cell, nx, ny):
    """The grid cells ``(x0, x1, y0, y1)``, inclusive and clipped to the grid, that the square
    ``(px, py) ± reach`` meets (a grid of ``nx`` × ``ny`` cells of side ``cell`` from ``origin``)."""
    inv = 1.0 / cell
    x0 = max(int(np.floor((px - reach - origin[0]) * inv)), 0)
    x1 = min(int(np.floor((px + reach - origin[0]) * inv)), nx - 1)
    y0 = max(int(np.floor((py - reach - origin[1]) * inv)), 0)
    y1 = min(int(np.floor((py + reach - origin[1]) * inv)), ny - 1)
    return x0, x1, y0, y1


@row_njit(inline="always")
def _box_dist_sq(px, py, x0, y0, x1, y1):
    dx = max(0.0, max(x0 - px, px - x1))
    dy = max(0.0, max(y0 - py, py - y1))
    return dx * dx + dy * dy


@row_njit(inline="always")
def _closer(j, dsq, count, max_neighbors, range_sq, out_idx):
    """Whether row ``j`` at squared distance ``dsq`` enters a list of ``count`` rows: nearer than
    the range (strictly, RVO2's test), or, once the list is full, exactly as far as its last row
    and before it by row. Equal distances go by row, so a list is a function of the positions
    alone, not of the order a search meets the rows in (issue 27: any grid, or the candidate
    lists of :func:`verlet_neighbors_kernel`, gives the same lists)."""
    return dsq < range_sq or (count == max_neighbors and dsq == range_sq and j < out_idx[count - 1])


@row_njit(inline="always")
def _insert_neighbor(j, dsq, count, max_neighbors, out_idx, out_dsq):
    """insertAgentNeighbor: sorted insert by (distance, row), the last dropped when full; returns
    the new count."""
    if count < max_neighbors:
        count += 1
    m = count - 1
    while m > 0 and (dsq < out_dsq[m - 1] or (dsq == out_dsq[m - 1] and j < out_idx[m - 1])):
        out_dsq[m] = out_dsq[m - 1]
        out_idx[m] = out_idx[m - 1]
        m -= 1
    out_dsq[m] = dsq
    out_idx[m] = j
    return count


@row_njit()
def agent_neighbors_of(i, px, py, range_sq, max_neighbors, origin, cell, nx, ny,
                       cell_start, order, sorted_pos, out_idx, out_dsq):
    """The ``max_neighbors`` nearest agents to agent ``i`` at ``(px, py)``.

    Writes neighbour rows and squared distances, nearest first (equal distances by row,
    :func:`_closer`), into ``out_idx[:count]`` / ``out_dsq[:count]`` and returns ``count``.
    Cells are visited ring by ring around the agent's cell; a ring is skipped once its
    nearest possible point is beyond the (shrinking) search range.
    """
    count = 0
    if max_neighbors <= 0:
        return 0
    ox = origin[0]
    oy = origin[1]
    inv = 1.0 / cell
    cx = int(np.floor((px - ox) * inv))
    cy = int(np.floor((py - oy) * inv))
    cx = min(max(cx, -1), nx)
    cy = min(max(cy, -1), ny)
    reach = int(np.ceil(np.sqrt(range_sq) * inv)) + 1
    for ring in range(reach + 1):
        if ring >= 2:
            gap = (ring - 1) * cell
            if gap * gap > range_sq:
                break
        y_lo = cy - ring
        y_hi = cy + ring
        for gy in range(max(y_lo, 0), min(y_hi, ny - 1) + 1):
            on_edge_row = gy == y_lo or gy == y_hi
            step = 1 if on_edge_row else 2 * ring
            if step == 0:
                step = 1
            gx = cx - ring
            while gx <= cx + ring:
                if 0 <= gx < nx:
                    x0 = ox + gx * cell
                    y0 = oy + gy * cell
                    if _box_dist_sq(px, py, x0, y0, x0 + cell, y0 + cell) <= range_sq:
                        c = gy * nx + gx
                        for k in range(cell_start[c], cell_start[c + 1]):
                            j = order[k]
                            if j == i:
                                continue
                            dx = px - sorted_pos[k, 0]
                            dy = py - sorted_pos[k, 1]
                            dsq = dx * dx + dy * dy
                            if _closer(j, dsq, count, max_neighbors, range_sq, out_idx):
                                count = _insert_neighbor(j, dsq, count, max_neighbors, out_idx, out_dsq)
                                if count == max_neighbors:
                                    range_sq = out_dsq[count - 1]
                gx += step
    return count


@row_njit(inline="always")
def _bound_from(i, px, py, pos, max_neighbors, prev_idx, prev_count, range_sq):
    """A search range for agent ``i`` no shorter than its ``max_neighbors``-th nearest neighbour:
    the farthest of the rows its last list held, where that list was full (any ``max_neighbors``
    distinct other rows bound it, wherever they now are); ``range_sq`` otherwise. Inclusive: a
    row exactly that far is still found."""
    if prev_count.shape[0] != pos.shape[0] or prev_count[i] < max_neighbors or max_neighbors <= 0:
        return range_sq
    b = 0.0
    for q in range(max_neighbors):
        j = prev_idx[i, q]
        if j == i or j < 0 or j >= pos.shape[0]:
            return range_sq
        dx = px - pos[j, 0]
        dy = py - pos[j, 1]
        b = max(b, dx * dx + dy * dy)
    return min(range_sq, b * (1.0 + 1e-12) + 1e-300)


@parallel_kernel(allocates=False)
def agent_neighbors_kernel(pos, neighbor_dist, max_neighbors, origin, cell, nx, ny,
                           cell_start, order, sorted_pos, out_idx, out_dsq, out_count, prev_idx, prev_count):
    """Batch form of :func:`agent_neighbors_of` for every row (parallel over agents).

    ``prev_idx``/``prev_count``: the lists of the last call on the same rows (or ``(0, K)``/``(0,)``
    arrays: none). Each row's search starts no wider than the farthest of its last neighbours now
    are (:func:`_bound_from`), so in a dense crowd the far cells and most sorted inserts are
    skipped; the lists are exactly those of a search from ``neighbor_dist``, since every row the
    bound leaves out is farther than the ``max_neighbors`` it holds. A row may read its own last
    list in ``out_idx`` (they may be one array): it reads before it writes, and only its own."""
    n = pos.shape[0]
    rsq = neighbor_dist * neighbor_dist
    for i in prange(n):
        px = pos[i, 0]
        py = pos[i, 1]
        r = _bound_from(i, px, py, pos, max_neighbors, prev_idx, prev_count, rsq)
        out_count[i] = agent_neighbors_of(i, px, py, r, max_neighbors, origin, cell, nx, ny, cell_start,
                                          order, sorted_pos, out_idx[i], out_dsq[i])


# --------------------------------------------------------------------------- candidate lists

VERLET_SKIN = 0.5  # m: how much farther than its neighbour range a row's candidates reach


@njit(cache=True)
def max_displacement_sq(pos, ref):
    """The largest squared distance between a row's ``pos`` and its ``ref`` (both ``(N, 2)``)."""
    worst = 0.0
    for i in range(pos.shape[0]):
        dx = pos[i, 0] - ref[i, 0]
        dy = pos[i, 1] - ref[i, 1]
        worst = max(worst, dx * dx + dy * dy)
    return worst


@row_njit()
def agents_within(i, px, py, range_sq, origin, cell, nx, ny, cell_start, order, sorted_pos, out, cap):
    """Rows other than ``i`` strictly within ``range_sq`` of ``(px, py)``: writes the first ``cap``
    to ``out`` and returns how many there are."""
    qx0, qx1, qy0, qy1 = cell_span(px, py, np.sqrt(range_sq), origin, cell, nx, ny)
    total = 0
    if qx0 > qx1:
        return 0  # the square lies beside the grid (its first cell's run would start past the end)
    for gy in range(qy0, qy1 + 1):
        # a grid row's cells qx0..qx1 lie side by side in the grid's order: one run of rows, the
        # same rows in the same order as cell by cell, without a loop per (mostly empty) cell
        for k in range(cell_start[gy * nx + qx0], cell_start[gy * nx + qx1 + 1]):
            j = order[k]
            if j == i:
                continue
            dx = px - sorted_pos[k, 0]
            dy = py - sorted_pos[k, 1]
            if dx * dx + dy * dy < range_sq:
                if total < cap:
                    out[total] = j
                total += 1
    return total


@row_njit()
def _sort_by_distance(px, py, pos, rows, m):
    """``rows[:m]`` sorted nearest first from ``(px, py)`` (insertion sort: a dozen rows)."""
    for a in range(1, m):
        j = rows[a]
        d = (pos[j, 0] - px) ** 2 + (pos[j, 1] - py) ** 2
        b = a
        while b > 0 and d < (pos[rows[b - 1], 0] - px) ** 2 + (pos[rows[b - 1], 1] - py) ** 2:
            rows[b] = rows[b - 1]
            b -= 1
        rows[b] = j


@parallel_kernel(allocates=False)
def verlet_candidates_kernel(pos, neighbor_dist, max_neighbors, skin, prev_idx, prev_count, origin, cell, nx,
                             ny, cell_start, order, sorted_pos, out_idx, out_count):
    """Each row's candidates ``out_idx[i, :out_count[i]]``, nearest first: the rows within ``skin``
    beyond a bound on its neighbour range now, the farthest its last ``max_neighbors`` neighbours
    (``prev_idx``/``prev_count``, :func:`_bound_from`) are now, or ``neighbor_dist`` where its last
    list was not full (or there is none); on the grid of these positions. A count above
    ``out_idx.shape[1]`` means the row did not fit (the caller makes room and calls again).
    :func:`verlet_neighbors_kernel` finds the lists of these positions among them, and the same
    lists as a whole search would for as long as no row has moved ``skin / 4`` from here
    (:func:`candidates_hold`). Sorted nearest first, they stay nearly in order while the crowd
    moves that little, so its sorted inserts rarely shift and its branches are predictable (4000
    random agents at 0.2 per m², the kernel alone: 0.65 ms unsorted, 0.11 ms sorted)."""
    cap = out_idx.shape[1]
    for i in prange(pos.shape[0]):
        if max_neighbors <= 0:
            out_count[i] = 0
            continue
        px = pos[i, 0]
        py = pos[i, 1]
        r = np.sqrt(_bound_from(i, px, py, pos, max_neighbors, prev_idx, prev_count,
                                neighbor_dist * neighbor_dist))
        m = agents_within(i, px, py, (r + skin) * (r + skin), origin, cell, nx, ny, cell_start, order,
                          sorted_pos, out_idx[i], cap)
        out_count[i] = m
        if m <= cap:
            _sort_by_distance(px, py, pos, out_idx[i], m)


@parallel_kernel(allocates=False)
def verlet_neighbors_kernel(pos, neighbor_dist, max_neighbors, cand_idx, cand_count, out_idx, out_dsq,
                            out_count):
    """:func:`agent_neighbors_kernel`'s lists, searched among each row's candidates
    (:func:`verlet_candidates_kernel`) instead of on a grid: the same lists, nearest first and equal
    distances by row (:func:`_closer`), while the candidates still hold them.

    Why they do (Verlet lists): let ``D`` be the farthest any row moved since the candidates were
    made and ``r`` row i's range then (the distance of its ``max_neighbors``-th nearest, or
    ``neighbor_dist`` where it had fewer; the candidates reach ``skin`` beyond a bound on it). Its
    ``max_neighbors`` nearest then are now within ``r + 2D``; a row that was not a candidate was
    ``r + skin`` or farther and is now farther than ``r + skin - 2D``, which is more than
    ``r + 2D`` while ``4D < skin``: never among the nearest (where the list was not full, never
    in range)."""
    rsq = neighbor_dist * neighbor_dist
    for i in prange(pos.shape[0]):
        px = pos[i, 0]
        py = pos[i, 1]
        range_sq = rsq
        count = 0
        if max_neighbors > 0:
            for q in range(cand_count[i]):
                j = cand_idx[i, q]
                dx = px - pos[j, 0]
                dy = py - pos[j, 1]
                dsq = dx * dx + dy * dy
                if _closer(j, dsq, count, max_neighbors, range_sq, out_idx[i]):
                    count = _insert_neighbor(j, dsq, count, max_neighbors, out_idx[i], out_dsq[i])
                    if count == max_neighbors:
                        range_sq = out_dsq[i, count - 1]
        out_count[i] = count


def candidates_hold(pos: np.ndarray, ref: np.ndarray, skin: float) -> bool:
    """Whether candidate lists made at ``ref`` still hold every list at ``pos``: no row moved
    ``skin / 4`` or more (with a margin for rounding)."""
    if pos.shape != ref.shape:
        return False
    return 16.0 * float(max_displacement_sq(pos, ref)) < (skin * (1.0 - 1e-9)) ** 2


NO_LISTS = np.zeros((0, 1), np.int64)  # agent_neighbors_kernel's prev_idx/prev_count: no last lists
NO_COUNTS = np.zeros(0, np.int64)


def agent_neighbors(pos: np.ndarray, *, neighbor_dist: float, max_neighbors: int,
                    cell_size: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Nearest neighbours of every agent.

    ``pos (N,2) float64`` → ``(idx (N,K) int64, count (N,) int64)`` with
    ``K = max_neighbors``; row ``i`` holds ``count[i]`` neighbour rows, nearest
    first; entries past the count are unspecified.
    """
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    n = pos.shape[0]
    k = int(max_neighbors)
    g = build_agent_grid(pos, cell_size if cell_size is not None else default_cell_size(neighbor_dist),
                         per_item=NEIGHBOR_CELLS_PER_AGENT)
    idx = np.zeros((n, max(k, 1)), np.int64)
    dsq = np.zeros((n, max(k, 1)))
    cnt = np.zeros(n, np.int64)
    agent_neighbors_kernel(pos, float(neighbor_dist), k, g.origin, g.cell, g.shape[0], g.shape[1],
                           g.cell_start, g.order, g.sorted_pos, idx, dsq, cnt, NO_LISTS, NO_COUNTS)
    return idx[:, :k], cnt


def default_cell_size(neighbor_dist: float) -> float:
    """Agent-grid cell side: a third of the neighbour distance.

    Small cells let the ring search stop early in dense crowds, where the K
    nearest are much closer than ``neighbor_dist``.
    """
    return max(float(neighbor_dist) / 3.0, 1e-3)


# --------------------------------------------------------------------------- obstacles


@njit(cache=True)
def _build_obstacle_grid_arrays(vertices, nxt, cell_size):
    m = vertices.shape[0]
    origin = np.zeros(2)
    if m == 0:
        return (origin, cell_size, 1, 1, np.zeros(2, np.int64), np.zeros(0, np.int64),
                np.zeros((0, 4), np.int64))
    minx = vertices[0, 0]
    maxx = minx
    miny = vertices[0, 1]
    maxy = miny
    for k in range(m):
        minx = min(minx, vertices[k, 0])
        maxx = max(maxx, vertices[k, 0])
        miny = min(miny, vertices[k, 1])
        maxy = max(maxy, vertices[k, 1])
    cell, nx, ny = _grid_shape(minx, maxx, miny, maxy, cell_size, m, MAX_CELLS_PER_ITEM)
    origin[0] = minx
    origin[1] = miny
    inv = 1.0 / cell
    edge_cells = np.empty((m, 4), np.int64)
    ncell = nx * ny
    cell_start = np.zeros(ncell + 1, np.int64)
    for k in range(m):
        a0 = vertices[k, 0]
        a1 = vertices[k, 1]
        b0 = vertices[nxt[k], 0]
        b1 = vertices[nxt[k], 1]
        x0 = min(int((min(a0, b0) - minx) * inv), nx - 1)
        x1 = min(int((max(a0, b0) - minx) * inv), nx - 1)
        y0 = min(int((min(a1, b1) - miny) * inv), ny - 1)
        y1 = min(int((max(a1, b1) - miny) * inv), ny - 1)
        edge_cells[k, 0] = x0
        edge_cells[k, 1] = y0
        edge_cells[k, 2] = x1
        edge_cells[k, 3] = y1
        for gy in range(y0, y1 + 1):
            for gx in range(x0, x1 + 1):
                cell_start[gy * nx + gx + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    cell_edges = np.empty(cell_start[ncell], np.int64)
    for k in range(m):
        for gy in range(edge_cells[k, 1], edge_cells[k, 3] + 1):
            for gx in range(edge_cells[k, 0], edge_cells[k, 2] + 1):
                c = gy * nx + gx
                cell_edges[fill[c]] = k
                fill[c] += 1
    return origin, cell, nx, ny, cell_start, cell_edges, edge_cells


def build_obstacle_grid(vertices: np.ndarray, nxt: np.ndarray, cell_size: float) -> ObstacleGrid:
    """File every edge ``k -> nxt[k]`` into the cells its bounding box touches."""
    o, c, nx, ny, cs, ce, ec = _build_obstacle_grid_arrays(
        np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(nxt, dtype=np.int64),
        float(cell_size))
    return ObstacleGrid(o, float(c), (int(nx), int(ny)), cs, ce, ec)


@row_njit(inline="always")
def dist_sq_point_segment(ax, ay, bx, by, px, py):
    """RVO2's ``distSqPointLineSegment``: squared distance from p to segment ab."""
    ex = bx - ax
    ey = by - ay
    r = ((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey)
    if r < 0.0:
        dx = px - ax
        dy = py - ay
    elif r > 1.0:
        dx = px - bx
        dy = py - by
    else:
        dx = px - (ax + r * ex)
        dy = py - (ay + r * ey)
    return dx * dx + dy * dy


@row_njit()
def edges_near(px, py, reach, origin, cell, nx, ny, cell_start, cell_edges, edge_cells,
               out_idx, capacity):
    """Every edge whose bounding-box cells meet the square ``p ± reach``, each once.

    Writes up to ``capacity`` edge indices into ``out_idx`` and returns how many
    there are in all (which may exceed ``capacity``; the caller then retries
    with more room). Order: by cell, then by edge index within a cell.
    """
    if cell_start.shape[0] <= 2 and cell_edges.shape[0] == 0:
        return 0
    qx0, qx1, qy0, qy1 = cell_span(px, py, reach, origin, cell, nx, ny)
    total = 0
    for gy in range(qy0, qy1 + 1):
        for gx in range(qx0, qx1 + 1):
            c = gy * nx + gx
            for s in range(cell_start[c], cell_start[c + 1]):
                k = cell_edges[s]
                # Handle edge k only in the first cell shared by its box and the query.
                if gx != max(edge_cells[k, 0], qx0) or gy != max(edge_cells[k, 1], qy0):
                    continue
                if total < capacity:
                    out_idx[total] = k
                total += 1
    return total


@row_njit()
def obstacle_neighbors_of(px, py, range_sq, vertices, nxt, origin, cell, nx, ny, cell_start,
                          cell_edges, edge_cells, out_idx, out_dsq):
    """Obstacle edges an agent at ``(px, py)`` takes into account (RVO2's rule).

    Fills ``out_idx``/``out_dsq`` (capacity = their length) with edges the
    agent sees from their right side within ``range_sq``, sorted by
    point–segment distance (stable). Returns the true count, which exceeds the
    capacity when the scratch was too small (entries are then incomplete).
    """
    capacity = out_idx.shape[0]
    if vertices.shape[0] == 0:
        return 0
    qx0, qx1, qy0, qy1 = cell_span(px, py, np.sqrt(range_sq), origin, cell, nx, ny)
    count = 0
    for gy in range(qy0, qy1 + 1):
        for gx in range(qx0, qx1 + 1):
            c = gy * nx + gx
            for s in range(cell_start[c], cell_start[c + 1]):
                k = cell_edges[s]
                if gx != max(edge_cells[k, 0], qx0) or gy != max(edge_cells[k, 1], qy0):
                    continue
                ax = vertices[k, 0]
                ay = vertices[k, 1]
                k2 = nxt[k]
                bx = vertices[k2, 0]
                by = vertices[k2, 1]
                # leftOf(a, b, p) = det(a - p, b - a): only edges seen from their right.
                left = (ax - px) * (by - ay) - (ay - py) * (bx - ax)
                if left >= 0.0:
                    continue
                dsq = dist_sq_point_segment(ax, ay, bx, by, px, py)
                if dsq >= range_sq:
                    continue
                if count < capacity:
                    m = count
                    # Stable sorted insert; equal distances keep edge-index order.
                    while m > 0 and (dsq < out_dsq[m - 1]
                                     or (dsq == out_dsq[m - 1] and k < out_idx[m - 1])):
                        out_dsq[m] = out_dsq[m - 1]
                        out_idx[m] = out_idx[m - 1]
                        m -= 1
                    out_dsq[m] = dsq
                    out_idx[m] = k
                count += 1
    return count


@parallel_kernel(allocates=False)
def obstacle_neighbors_kernel(pos, ranges_sq, vertices, nxt, origin, cell, nx, ny, cell_start,
                              cell_edges, edge_cells, out_idx, out_dsq, out_count):
    """Batch form of :func:`obstacle_neighbors_of` (parallel over agents)."""
    for i in prange(pos.shape[0]):
        out_count[i] = obstacle_neighbors_of(pos[i, 0], pos[i, 1], ranges_sq[i], vertices, nxt,
                                             origin, cell, nx, ny, cell_start, cell_edges,
                                             edge_cells, out_idx[i], out_dsq[i])


def obstacle_neighbors(pos: np.ndarray, ranges_sq: np.ndarray, vertices: np.ndarray,
                       nxt: np.ndarray, grid: ObstacleGrid) -> tuple[np.ndarray, np.ndarray]:
    """Obstacle neighbours of every agent (for tests and tools).

    ``pos (N,2)``, ``ranges_sq (N,)`` (RVO2: ``(time_horizon_obst*max_speed +
    radius)**2``) → ``(idx (N,Q) int64, count (N,) int64)``, nearest first.
    """
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    n = pos.shape[0]
    cap = max(1, min(16, vertices.shape[0]))
    while True:
        idx = np.full((n, cap), -1, np.int64)
        dsq = np.zeros((n, cap))
        cnt = np.zeros(n, np.int64)
        obstacle_neighbors_kernel(pos, np.ascontiguousarray(ranges_sq, dtype=np.float64), vertices,
                                  nxt, grid.origin, grid.cell, grid.shape[0], grid.shape[1],
                                  grid.cell_start, grid.cell_edges, grid.edge_cells, idx, dsq, cnt)
        need = int(cnt.max()) if n else 0
        if need <= cap:
            return idx, cnt
        cap = need
