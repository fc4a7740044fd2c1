import numpy as np
import pytest
import shapely
from _world_helpers import box_obstacle, random_box_world

from pedvr.scene.config import WorldConfig
from pedvr.world import Visibility
from pedvr.world.visibility import raycast, segment_clear, visible_batch


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(12)
    world = random_box_world(rng, 8, 10.0)
    vis = Visibility(world)
    walls = shapely.MultiLineString(list(np.stack([vis.p1, vis.p2], axis=1)))
    return rng, vis, walls


def test_segment_clear_and_batch_agree_with_shapely(scene):
    rng, vis, walls = scene
    a = rng.uniform(-0.5, 10.5, (500, 2))
    b = a + rng.normal(0, 3, (500, 2))
    radius = rng.uniform(0, 0.5, 500)
    dist = shapely.distance(walls, shapely.linestrings(np.stack([a, b], axis=1)))
    expected = dist > radius
    got = np.array([segment_clear(*a[i], *b[i], radius[i], vis.p1, vis.p2) for i in range(500)])
    decided = np.abs(dist - radius) > 1e-9
    assert 50 < expected.sum() < 450  # both outcomes are exercised
    np.testing.assert_array_equal(got[decided], expected[decided])
    out = np.empty(500, bool)
    visible_batch(a, b, radius, vis.p1, vis.p2, out)
    np.testing.assert_array_equal(out, got)
    np.testing.assert_array_equal(vis.visible(a, b, radius), got)


def test_raycast_agrees_with_shapely(scene):
    rng, vis, walls = scene
    for _ in range(500):
        o = rng.uniform(0.1, 9.9, 2)
        ang = rng.uniform(0, 2 * np.pi)
        u = np.array([np.cos(ang), np.sin(ang)])
        hit = shapely.intersection(walls, shapely.LineString([o, o + 30 * u]))
        pts = shapely.get_coordinates(hit)
        expected = min(np.linalg.norm(pts - o, axis=1).min(), 30.0) if len(pts) else 30.0
        assert raycast(o[0], o[1], u[0], u[1], 30.0, vis.p1, vis.p2) == pytest.approx(expected, abs=1e-9)
        assert vis.raycast(o, 2 * u, 30.0) == pytest.approx(expected, abs=1e-9)
    assert vis.raycast((5.0, 5.0), (1.0, 0.0), 0.1) <= 0.1


# An L-shaped corridor: walls fill the room except x < 2 or y > 8.
CORNER = WorldConfig(((0, 0), (10, 10)), (box_obstacle(2, -1, 11, 8),))


def test_furthest_visible_skips_visible_waypoints_and_stops_at_corners():
    vis = Visibility(CORNER)
    # Agent 0: a straight run of waypoints up the corridor, then around the corner.
    path0 = np.array([[1, 0.5], [1, 2], [1, 4], [1, 6], [1.0, 8.7], [4, 9], [8, 9]], float)
    # Agent 1: already past its last waypoint index; agent 2: no path.
    path1 = np.array([[1, 1], [1, 2]], float)
    path_pts = np.concatenate([path0, path1])
    pos = np.array([[1, 0.5], [1, 1], [5, 5]], float)
    start = np.array([0, 7, 0])
    length = np.array([7, 2, 0])
    cursor = np.array([0, 5, 3])
    out = vis.furthest_visible(pos, 0.3, path_pts, start, length, cursor, lookahead=10)
    # Waypoint 4 (x=1, y=8.7) is in view up the corridor; 5 and 6 are behind the corner.
    assert out[0] == 4
    assert out[1] == 5  # never backward
    assert out[2] == 3  # no path: cursor kept
    # lookahead bounds the jump
    out = vis.furthest_visible(pos, 0.3, path_pts, start, length, cursor, lookahead=2)
    assert out[0] == 2
    # Standing at the corner, the rest of the path is in view.
    out = vis.furthest_visible([[1.0, 8.7]], 0.3, path_pts, [0], [7], [4], lookahead=10)
    assert out[0] == 6
    # A wide clearance hides the far waypoint beyond the corner even from close by.
    out = vis.furthest_visible([[1.0, 8.0]], 1.6, path_pts, [0], [7], [4], lookahead=10)
    assert out[0] == 4


def test_furthest_visible_rejects_bad_slices():
    vis = Visibility(CORNER)
    with pytest.raises(ValueError, match="path slice"):
        vis.furthest_visible([[1.0, 1.0]], 0.3, np.zeros((3, 2)), [2], [5], [0], lookahead=3)


@pytest.mark.parametrize("cell", [0.5, 4.0, 16.0])
def test_edge_grid_answers_exactly_as_a_scan_of_every_edge(cell):
    """Dense forest-like world; long, short, axis-aligned and zero-length segments."""
    from pedvr.world.visibility import EdgeGrid, visible_batch_grid

    rng = np.random.default_rng(5)
    world = random_box_world(rng, 120, 60.0)
    vis = Visibility(world)
    grid = EdgeGrid.build(vis.p1, vis.p2, cell=cell)
    n = 3000
    a = rng.uniform(-1.0, 61.0, (n, 2))
    b = a + rng.normal(0, 8, (n, 2))
    b[:300, 0] = a[:300, 0]  # vertical
    b[300:600, 1] = a[300:600, 1]  # horizontal
    b[600:700] = a[600:700]  # points
    radius = rng.uniform(0, 1.5, n)
    brute = np.array([segment_clear(*a[i], *b[i], radius[i], vis.p1, vis.p2) for i in range(n)])
    out = np.empty(n, bool)
    visible_batch_grid(a, b, radius, vis.p1, vis.p2, *grid, out)
    assert 300 < brute.sum() < n - 300  # both outcomes are exercised
    np.testing.assert_array_equal(out, brute)


def test_every_edge_is_filed_in_every_cell_its_box_touches():
    from pedvr.world.visibility import EdgeGrid

    rng = np.random.default_rng(2)
    p1 = rng.uniform(0, 20, (200, 2))
    p2 = p1 + rng.normal(0, 3, (200, 2))
    g = EdgeGrid.build(p1, p2, cell=2.0)
    nx, ny = g.shape
    lo, hi = np.minimum(p1, p2), np.maximum(p1, p2)
    for k in range(200):
        i0 = ((lo[k] - g.origin) // g.cell).astype(int)
        i1 = ((hi[k] - g.origin) // g.cell).astype(int)
        for ix in range(i0[0], min(i1[0], nx - 1) + 1):
            for iy in range(i0[1], min(i1[1], ny - 1) + 1):
                c = ix * ny + iy
                assert k in g.items[g.start[c]:g.start[c + 1]]
    assert g.start[-1] == len(g.items)


def test_one_row_or_many_scalar_or_array_radius_is_one_specialisation():
    """Issue 27 goal 2: a scalar radius broadcast to one row was a read-only array, which numba
    compiled as a second specialisation of the batch kernel, mid-run after ``pedvr prepare``."""
    from pedvr.world import visibility_kernels as vk

    vis = Visibility(WorldConfig(bounds=((-5.0, -5.0), (5.0, 5.0)), obstacles=(box_obstacle(-1, -1, 1, 1),)))
    a = np.array([[-3.0, 0.0], [-3.0, 3.0], [0.0, 3.0]])
    b = np.array([[3.0, 0.0], [3.0, 3.0], [0.0, -3.0]])
    got = [vis.visible(a[:1], b[:1]), vis.visible(a, b), vis.visible(a, b, np.full(3, 0.1)),
           vis.visible(a[:1], b[:1], 0.2)]
    assert [g.tolist() for g in got] == [[False], [False, True, False], [False, True, False], [False]]
    sigs = [str(s) for s in vk.visible_batch_grid.serial.signatures]
    assert sigs and all(", True, aligned" not in s for s in sigs), sigs  # no read-only array: one kind
