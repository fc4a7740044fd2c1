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
