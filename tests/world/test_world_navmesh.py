
import numpy as np
import pytest
import shapely
import shapely.ops
from _world_helpers import (
    box_obstacle,
    obstacles_geometry,
    path_length,
    random_box_world,
    visibility_graph_shortest,
)

from pedvr.errors import NavigationError
from pedvr.scene.config import WorldConfig
from pedvr.world import NavMesh, walkable_area

R = 0.25
EMPTY = WorldConfig(((0, 0), (10, 8)))
# A wall across the room with a 2 m gap near the top.
WALL = WorldConfig(((0, 0), (10, 10)), (box_obstacle(4.8, -1, 5.2, 7.5, kind="wall"),))
# A wall that cuts the room in two.
SPLIT = WorldConfig(((0, 0), (10, 10)), (box_obstacle(4.8, -1, 5.2, 11, kind="wall"),))


def _triangles(mesh: NavMesh) -> np.ndarray:
    return shapely.polygons(mesh.verts[mesh.tris])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_triangles_cover_shrunk_area_without_overlap(seed):
    world = random_box_world(np.random.default_rng(seed), 12, 15.0)
    mesh = NavMesh.build(world, clearance=R)
    tris = _triangles(mesh)
    shrunk = walkable_area(world).buffer(-R)
    # The mesh is the shrunk area (a little smaller at rounded corners, see NavMesh docs).
    assert mesh.area == pytest.approx(mesh.polygon.area, rel=1e-6)
    assert shapely.union_all(tris).area == pytest.approx(mesh.area, rel=1e-6)  # no overlaps
    assert mesh.polygon.area <= shrunk.area + 1e-9
    assert mesh.polygon.area >= shrunk.area * 0.99
    # No triangle comes within the clearance of an obstacle.
    blocked = obstacles_geometry(world)
    assert shapely.distance(blocked, tris).min() >= R - 1e-6
    assert (mesh.tri_area > 0).all()


def test_empty_room_path_is_the_straight_segment():
    mesh = NavMesh.build(EMPTY, clearance=R)
    path = mesh.find_path((1.0, 1.0), (9.0, 7.0))
    np.testing.assert_array_equal(path, [[1.0, 1.0], [9.0, 7.0]])


@pytest.mark.parametrize(("start", "goal"), [((2, 2), (8, 2)), ((1, 5), (9, 1)), ((2, 9), (9, 2))])
def test_path_around_wall_keeps_clearance_and_is_near_shortest(start, goal):
    mesh = NavMesh.build(WALL, clearance=R)
    path = mesh.find_path(start, goal)
    np.testing.assert_array_equal(path[0], start)
    np.testing.assert_array_equal(path[-1], goal)
    line = shapely.LineString(path)
    assert shapely.distance(obstacles_geometry(WALL), line) >= R - 1e-6
    best = visibility_graph_shortest(mesh.polygon, np.array(start), np.array(goal))
    assert path_length(path) <= 1.01 * best
    assert path_length(path) >= best - 1e-9
    if start[1] < 7 and goal[1] < 7:
        assert len(path) >= 4  # has to go up through the gap and down again


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_paths_in_box_worlds_are_near_shortest(seed):
    rng = np.random.default_rng(seed)
    world = random_box_world(rng, 6, 20.0)
    mesh = NavMesh.build(world, clearance=R)
    blocked = obstacles_geometry(world)
    for _ in range(8):
        s, g = np.array(mesh.random_point(rng)), np.array(mesh.random_point(rng))
        if not mesh.same_component(s, g):
            continue
        path = mesh.find_path(s, g)
        assert shapely.distance(blocked, shapely.LineString(path)) >= R - 1e-6
        assert path_length(path) <= 1.01 * visibility_graph_shortest(mesh.polygon, s, g)


def test_unreachable_goal_names_both_points():
    mesh = NavMesh.build(SPLIT, clearance=R)
    assert mesh.n_components == 2
    assert not mesh.same_component((2, 5), (8, 5))
    assert mesh.same_component((2, 5), (1, 1))
    with pytest.raises(NavigationError, match=r"\(2\.000, 5\.000\).*\(8\.000, 5\.000\)"):
        mesh.find_path((2, 5), (8, 5))


def test_gap_narrower_than_a_disc_is_closed():
    walls = (box_obstacle(4.8, -1, 5.2, 5), box_obstacle(4.8, 5.45, 5.2, 11))
    gap = WorldConfig(((0, 0), (10, 10)), walls)
    assert NavMesh.build(gap, clearance=0.2).n_components == 1  # 0.45 m gap fits a 0.4 m disc
    assert NavMesh.build(gap, clearance=R).n_components == 2


def test_start_and_goal_outside_are_snapped_inside():
    mesh = NavMesh.build(WALL, clearance=R)
    start, goal = (5.0, 3.0), (10.5, 0.0)  # inside the wall; outside the room
    path = mesh.find_path(start, goal)
    assert mesh.contains(path[0]) and mesh.contains(path[-1])
    blocked = obstacles_geometry(WALL)
    assert shapely.distance(blocked, shapely.LineString(path)) >= R - 1e-6
    snapped = np.array(mesh.nearest_walkable(goal))
    np.testing.assert_array_equal(snapped, path[-1])
    # The nearest mesh point is the mesh's bottom-right corner; snapping steps 2 mm inside.
    corner = np.array(shapely.ops.nearest_points(mesh.polygon, shapely.Point(goal))[0].coords[0])
    assert np.linalg.norm(corner - [10 - R, R]) < 0.01
    assert 0.0 < np.linalg.norm(snapped - corner) <= 0.002 + 1e-12
    assert mesh.nearest_walkable((3.0, 3.0)) == (3.0, 3.0)


def test_same_inputs_give_same_path():
    rng = np.random.default_rng(7)
    world = random_box_world(rng, 10, 20.0)
    a, b = NavMesh.build(world, clearance=R), NavMesh.build(world, clearance=R)
    np.testing.assert_array_equal(a.tris, b.tris)
    np.testing.assert_array_equal(a.verts, b.verts)
    for _ in range(10):
        s, g = a.random_point(rng), a.random_point(rng)
        if a.same_component(s, g):
            p = a.find_path(s, g)
            np.testing.assert_array_equal(p, b.find_path(s, g))
            np.testing.assert_array_equal(p, a.find_path(s, g))


def test_locate_agrees_with_triangle_geometry():
    rng = np.random.default_rng(8)
    world = random_box_world(rng, 10, 20.0)
    mesh = NavMesh.build(world, clearance=R)
    pts = rng.uniform(-1, 21, (4000, 2))
    tri = mesh.locate(pts)
    assert tri.dtype == np.int64 and tri.shape == (4000,)
    inside = tri >= 0
    polys = _triangles(mesh)
    assert shapely.distance(polys[tri[inside]], shapely.points(pts[inside])).max() < 1e-8
    dist_out = shapely.distance(mesh.polygon, shapely.points(pts[~inside]))
    assert dist_out.min() > 0.0
    clearly_in = shapely.contains_xy(mesh.polygon.buffer(-1e-6), pts[:, 0], pts[:, 1])
    assert inside[clearly_in].all()
    assert mesh.locate(np.array([[np.nan, 1.0]]))[0] == -1


def test_random_point_is_uniform_over_the_mesh():
    mesh = NavMesh.build(WALL, clearance=R)
    rng = np.random.default_rng(9)
    pts = np.array([mesh.random_point(rng) for _ in range(20000)])
    assert (mesh.locate(pts) >= 0).all()
    centroid = np.array(mesh.polygon.centroid.coords[0])
    # Coordinate spread is about 3 m, so the standard error of the mean is about 0.02 m.
    assert np.linalg.norm(pts.mean(axis=0) - centroid) < 0.1
    # Same seed, same points.
    again = np.random.default_rng(9)
    assert mesh.random_point(again) == tuple(pts[0])


def test_random_point_in_region():
    mesh = NavMesh.build(WALL, clearance=R)
    rng = np.random.default_rng(10)
    region = shapely.box(3, 2, 7, 9)
    pts = np.array([mesh.random_point(rng, region) for _ in range(2000)])
    assert shapely.contains_xy(region.buffer(1e-9), pts[:, 0], pts[:, 1]).all()
    assert (mesh.locate(pts) >= 0).all()
    expected = shapely.intersection(mesh.polygon, region).centroid
    assert np.linalg.norm(pts.mean(axis=0) - expected.coords[0]) < 0.15
    with pytest.raises(NavigationError, match="region with bounds"):
        mesh.random_point(rng, shapely.box(4.9, 0, 5.1, 3))  # inside the wall


def test_bad_clearance_and_full_world_rejected():
    with pytest.raises(NavigationError, match="clearance = -1"):
        NavMesh.build(EMPTY, clearance=-1.0)
    with pytest.raises(NavigationError, match="no walkable area"):
        NavMesh.build(EMPTY, clearance=5.0)


def _left_of(u: np.ndarray, v: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Twice the signed area of (u, v, p), row by row: > 0 where p is left of u -> v."""
    return (v[:, 0] - u[:, 0]) * (p[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (p[:, 0] - u[:, 0])


def test_large_worlds_build_and_locate_every_sampled_point():
    """60 random boxes in 40 m, and a SteerSuite-sized 200 x 200 m world with six boxes: every
    point sampled on the mesh is located in a triangle that holds it. (Build and locate times are
    a benchmark's, ``python bench/paths.py``, not a test's: CI machines are shared.)"""
    crowded = random_box_world(np.random.default_rng(11), 60, 40.0)
    corners = [(x, y) for x in (-80.0, 0.0, 80.0) for y in (-80.0, 80.0)]
    steer = WorldConfig(((-100, -100), (100, 100)),
                        tuple(box_obstacle(x, y, x + 2, y + 3) for x, y in corners))
    for world in (crowded, steer):
        mesh = NavMesh.build(world, clearance=R)
        rng = np.random.default_rng(0)
        pts = np.array([mesh.random_point(rng) for _ in range(100)])
        tri = mesh.locate(pts)
        assert (tri >= 0).all()
        a, b, c = (mesh.verts[mesh.tris[tri, k]] for k in range(3))
        sides = [_left_of(u, v, pts) for u, v in ((a, b), (b, c), (c, a))]  # CCW: inside is left of each edge
        assert (np.min(sides, axis=0) >= -1e-9).all()


# -- narrow passages (issue 26) ----------------------------------------------------------------

def _slot_world(gap: float, wall_x: float = 5.0) -> WorldConfig:
    """A 10 x 10 room cut by a wall at x = wall_x, open at one ``gap`` wide slot (y 5 ± gap/2)."""
    return WorldConfig(((0.0, 0.0), (10.0, 10.0)),
                       (box_obstacle(wall_x - 0.5, 0.0, wall_x + 0.5, 5.0 - gap / 2),
                        box_obstacle(wall_x - 0.5, 5.0 + gap / 2, wall_x + 0.5, 10.0)))


def test_a_gap_a_turned_body_fits_through_is_open_on_a_narrow_mesh():
    """0.5 m: closed for a 0.25 m disc, open for a body turned to 0.13 m (real people pass it)."""
    world = _slot_world(0.5)
    strict = NavMesh.build(world, 0.25)
    mesh = NavMesh.build(world, 0.25, narrow=0.13)
    assert strict.n_components == 2 and mesh.n_components == 1
    path = mesh.find_path((2.0, 5.0), (8.0, 5.0))
    np.testing.assert_allclose(path[[0, -1]], [(2.0, 5.0), (8.0, 5.0)])
    inside = path[:, 0]
    assert inside.min() <= 4.5 and inside.max() >= 5.5  # through the slot
    obstacles = obstacles_geometry(world)
    line = shapely.LineString(path)
    assert line.distance(obstacles) >= 0.13 - 1e-6  # a turned body's depth from the walls
    assert mesh.narrow.any() and not mesh.narrow[mesh.locate(np.array([[2.0, 5.0], [8.0, 5.0]]))].any()
    # a gap even a turned body does not fit stays closed
    assert NavMesh.build(_slot_world(0.24), 0.25, narrow=0.13).n_components == 2
    # where the full radius fits, nothing is added
    wide = _slot_world(0.7)
    assert NavMesh.build(wide, 0.25, narrow=0.13).area == pytest.approx(NavMesh.build(wide, 0.25).area)


def test_a_narrow_passage_costs_more_than_the_way_round():
    """A* counts metres through a narrow passage NARROW_COST times: a slightly longer way round
    through a wide gap wins, a much longer one does not."""
    from pedvr.world.navmesh import NARROW_COST

    def world(detour_gap_y: float) -> WorldConfig:
        # wall at x 4.5..5.5 with a 0.5 m slot at y = 5 and a 1.2 m gap at y = detour_gap_y
        return WorldConfig(((0.0, 0.0), (10.0, 20.0)), (
            box_obstacle(4.5, 0.0, 5.5, 4.75), box_obstacle(4.5, 5.25, 5.5, detour_gap_y - 0.6),
            box_obstacle(4.5, detour_gap_y + 0.6, 5.5, 20.0)))

    assert NARROW_COST > 1.0
    near = NavMesh.build(world(7.0), 0.25, narrow=0.13).find_path((3.0, 5.0), (7.0, 5.0))
    assert near[:, 1].max() > 6.0  # 2 m round beats 1 m narrow at 3x
    far = NavMesh.build(world(18.0), 0.25, narrow=0.13).find_path((3.0, 5.0), (7.0, 5.0))
    assert far[:, 1].max() < 5.5  # 26 m round does not


def test_narrow_must_be_below_the_clearance():
    with pytest.raises(NavigationError, match=r"narrow = 0.3: must be a number in \(0, clearance = 0.25\)"):
        NavMesh.build(_slot_world(0.5), 0.25, narrow=0.3)
