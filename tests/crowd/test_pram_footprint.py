"""A pushed perambulator's longer footprint (issue 14, Huang & Terzopoulos §4.6): pusher and pram are
one ellipse ahead of the body (:mod:`pedvr.crowd.footprint`), steered, pushed apart and measured as
such. Checked here against the true geometry, independently of the kernels' support-function
approximation: the ellipse never overlaps another body, a door leaf or a wall by more than 1 cm, and
nothing enters the user's disc."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from pedvr.body import carry
from pedvr.body import skeleton as sk
from pedvr.crowd.footprint import covering_discs, enclosing_ellipse, footprints
from pedvr.errors import SceneError
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

TOL = 0.01  # m

CORRIDOR = """
[scene]
name = "pram_corridor"
seed = 5
duration = 30.0

[world]
bounds = [[-9.0, -3.0], [9.0, 3.0]]

[[world.obstacles]]
kind = "wall"
polygon = [[-5.0, 0.8], [5.0, 0.8], [5.0, 3.0], [-5.0, 3.0]]

[[world.obstacles]]
kind = "wall"
polygon = [[-5.0, -3.0], [5.0, -3.0], [5.0, -0.8], [-5.0, -0.8]]

[agents.profiles.walker]
radius = 0.25
pref_speed = 1.3
max_speed = 1.6

[agents.profiles.pram]
inherit = "walker"
radius = 0.4
pref_speed = 1.0
max_speed = 1.4
carrying = "perambulator"

[[agents.spawns]]
profile = "pram"
state = "east"
positions = [[-7.5, 0.0]]
facing_deg = 0

[[agents.spawns]]
profile = "walker"
state = "west"
positions = [[6.5, 0.4], [7.2, -0.5], [8.0, 0.2]]
facing_deg = 180

[behavior.states.east]
goal = { selector = "point", at = [7.5, 0.0] }
arrive_dist = 0.4

[behavior.states.west]
goal = { selector = "point", at = [-7.5, 0.0] }
arrive_dist = 0.4

[user]
start = [-6.0, -2.0]
heading_deg = 0
route = [[-4.0, 0.3], [4.0, 0.3], [7.0, -2.0]]
"""


# The user pushes the pram (a study protocol's participant_carrying, or [user] carrying) down the
# corridor's right half, straight at three walkers on the same line: the user is not steered, so
# they must step round the pram's front, which reaches 1.2 m ahead of the user.
USER_PRAM = CORRIDOR.replace("""[[agents.spawns]]
profile = "pram"
state = "east"
positions = [[-7.5, 0.0]]
facing_deg = 0
""", "").replace("positions = [[6.5, 0.4], [7.2, -0.5], [8.0, 0.2]]",
                 "positions = [[6.0, -0.3], [7.0, -0.3], [8.0, -0.3]]").split("[user]")[0] + """[user]
start = [-7.5, -0.3]
heading_deg = 0
route = [[7.5, -0.3]]
carrying = "perambulator"
"""


_DIRS = np.stack([np.cos(np.linspace(0.0, 2.0 * np.pi, 1440, endpoint=False)),
                  np.sin(np.linspace(0.0, 2.0 * np.pi, 1440, endpoint=False))], axis=1)


def _ellipse_support(centre: np.ndarray, a: float, b: float, facing: np.ndarray) -> np.ndarray:
    """Exact support function of an ellipse over :data:`_DIRS` (``a`` along the kernels' long axis
    ``(-f_y, f_x)``, ``b`` along ``facing``), centre included."""
    u = np.array([-facing[1], facing[0]])
    return _DIRS @ centre + np.sqrt(a * a * (_DIRS @ u) ** 2 + b * b * (_DIRS @ facing) ** 2)


def _points_support(points: np.ndarray) -> np.ndarray:
    """Support function of the convex hull of ``points`` over :data:`_DIRS`."""
    return (_DIRS @ np.asarray(points, np.float64).T).max(axis=1)


def _penetration(h_a: np.ndarray, h_b: np.ndarray) -> float:
    """Penetration depth of two convex bodies from their support functions: the least overlap of
    their projections over all directions (separating-axis theorem); <= 0 when apart. Exact up to
    the direction sampling (a quarter degree), unlike the kernels' one direction (the line of
    centres), which overestimates it."""
    return float((h_a + h_b[_OPP]).min())


_OPP = (np.arange(len(_DIRS)) + len(_DIRS) // 2) % len(_DIRS)  # the index of -n


@functools.cache
def _measure(which: str, seconds: float) -> dict[str, float]:
    """Run a scene and measure, every step, the pram footprints' true overlaps."""
    if which == "door_assist":
        scene = load_scene(resolve_scene("door_assist"))
    else:
        path = Path(__file__).with_name("_pram_corridor.toml")
        path.write_text(USER_PRAM if which == "user_pram" else CORRIDOR)
        try:
            scene = load_scene(path)
        finally:
            path.unlink()
    sim = Simulation(scene, seed=scene.seed)
    walls = [_points_support(ob.vertices) for ob in scene.world.obstacles]  # convex blocks here
    out = {"agents": 0.0, "leaves": 0.0, "walls": 0.0, "user": 0.0, "moved": 0.0, "box_hands": 0.0,
           "pram_hands": 0.0, "reached": 0.0, "forced": 0.0, "user_pram": 0.0, "user_pram_near": math.inf}
    b = sim.body.state
    c = sim.crowd
    start = c.pos[c.length > 0.0].copy()  # the pram pushers (their footprint reaches ahead)
    for _ in range(round(seconds / sim.dt)):
        sim.step()
        c = sim.crowd
        # Carriers' hands: on what they carry, unless one was freed (§4.6, after CARRIER_PATIENCE).
        holds = (b.carrying != carry.NONE) & ~b.reach_on.any(axis=1)
        if holds.any():
            # the drawn box's sides (its frame, carry.object_frame) and the pram's handle ends
            frame = b.carry_frame
            yaw, tilt = frame[:, 3], frame[:, 4]  # a box tilts in the hands (its left side up)
            side = np.stack([np.sin(yaw) * np.cos(tilt), np.sin(tilt), -np.cos(yaw) * np.cos(tilt)], axis=1)
            fwd = np.stack([np.cos(yaw), np.zeros_like(yaw), np.sin(yaw)], axis=1)
            box = (b.carrying == carry.BOX)[:, None]
            sc = b.dims[:, 3:4]
            half = np.where(box, carry.BOX_SIZE[2] / 2 * sc, carry.PRAM_HANDLE_WIDTH / 2)
            mid = np.where(box, frame[:, :3], frame[:, :3] + fwd * carry.PRAM_HANDLE_AHEAD
                           + np.array([0.0, carry.PRAM_HANDLE_HEIGHT, 0.0]))
            want = np.stack([mid + side * half, mid - side * half], axis=1)
            got = b.world_pos[:, [sk.L_HAND, sk.R_HAND]]
            off = np.linalg.norm(got - want, axis=2).max(axis=1)
            for kind, key in ((carry.BOX, "box_hands"), (carry.PERAMBULATOR, "pram_hands")):
                rows = holds & (b.carrying == kind)
                if rows.any():
                    out[key] = max(out[key], float(off[rows].max()))
        # a carrier reaching for anything but what it carries, without having freed a hand (§4.6)
        freed = [] if sim.etiquette is None else [w.id for w in sim.etiquette.walkers.values() if w.freed_hand]
        if np.any((b.carrying != carry.NONE) & b.reach_on.any(axis=1) & ~np.isin(c.ids, freed)):
            out["reached"] += sim.dt
        if sim.etiquette is not None:
            out["forced"] = float(sim.etiquette.carrier_forced)
        # the farthest the pram got from where it started (a round trip through the door ends near it)
        out["moved"] = max(out["moved"], float(np.hypot(*(c.pos[c.length > 0.0] - start).T).max(initial=0.0)))
        fp = footprints(c.pos, c.radius, c.turn, c.torso, c.heading, c.ahead, c.length)
        for i in np.flatnonzero(fp.rigid):
            h_i = _ellipse_support(fp.centre[i], float(fp.radius[i]), float(fp.depth[i]), fp.facing[i])
            for j in range(len(c)):
                if j == i or np.hypot(*(fp.centre[j] - fp.centre[i])) > fp.radius[i] + fp.radius[j]:
                    continue
                h_j = _ellipse_support(fp.centre[j], float(fp.radius[j]), float(fp.depth[j]), fp.facing[j])
                key = "user" if c.is_user[j] else "agents"
                out[key] = max(out[key], _penetration(h_i, h_j))
            for h_w in walls:
                out["walls"] = max(out["walls"], _penetration(h_i, h_w))
            for h, tip in zip(sim.doors.hinge, sim.doors.tips(), strict=True):
                out["leaves"] = max(out["leaves"], _penetration(h_i, _points_support([h, tip])))
        if scene.user is not None and scene.user.carrying == "perambulator":
            # The user's pram from the geometry alone (not from the crowd's footprint arrays): the
            # hull of pusher and pram round the user's position and heading, every walker's disc.
            u = int(np.flatnonzero(c.is_user)[0])
            h = float(c.heading[u])
            rot = np.array([[math.cos(h), -math.sin(h)], [math.sin(h), math.cos(h)]])
            h_u = _points_support(c.pos[u] + carry.PRAM_HULL @ rot.T)
            for j in np.flatnonzero(~c.is_user):
                gap = float(np.hypot(*(c.pos[j] - c.pos[u])))
                if gap < 2.0:
                    out["user_pram"] = max(out["user_pram"], _penetration(h_u, _DIRS @ c.pos[j] + c.radius[j]))
                    out["user_pram_near"] = min(out["user_pram_near"], -_penetration(h_u, _DIRS @ c.pos[j]
                                                                                         + c.radius[j]))
    out["max_overlap"] = sim.metrics.max_overlap
    out["door_push"] = sim.metrics.door_push
    return out


@pytest.mark.parametrize("which,seconds", [("door_assist", 90.0), ("corridor", 20.0)])
def test_a_pram_overlaps_nobody_no_leaf_no_wall(which: str, seconds: float) -> None:
    m = _measure(which, seconds)
    assert m["moved"] > 3.0, m  # the pram went somewhere (through the door / along the corridor)
    assert m["agents"] <= TOL, m
    assert m["leaves"] <= TOL, m
    assert m["walls"] <= TOL, m
    assert m["user"] <= 1e-3, m  # nothing inside the user
    assert m["max_overlap"] <= TOL, m  # and the simulation's own measure agrees
    # a leaf never shoves the pram: its pusher, nearly still beside a leaf at its stop, once swung
    # the pram's front into it every other step (3.5 cm shoves at 70 s in door_assist)
    assert m["door_push"] <= TOL, m


def test_door_assist_carriers_keep_both_hands_on_what_they_carry() -> None:
    """Issue 14: a carrier has no free hand: through the whole door_assist run the box carrier's and
    the pram pusher's hands stay on the box's sides and the handle's ends (no handle reached for),
    unless the etiquette let a carrier free a hand after waiting alone (§4.6, at most once here)."""
    m = _measure("door_assist", 90.0)
    # no hand ever left what it carries (no handle reached for) but a freed one: the etiquette's
    # fallback may decide once that a carrier frees a hand (with issue 26's crowd model the pram
    # did, at 57.8 s, and its helper opened the door 0.2 s later, before any reach; since stop 37's
    # pram the box carrier does, at 61.1 s, and opens the pull side itself)
    assert m["reached"] == 0.0 and m["forced"] <= 1.0, m
    assert m["box_hands"] < 0.01, m  # the box is drawn between the hands
    # the handle stays put and the hands stay on it as the knees bend: the arms are solved again
    # after the legs' IK (it was up to 6 cm before: pedvr.body.graph._arms_again)
    assert m["pram_hands"] < 0.005, m


def test_the_footprint_holds_pusher_and_pram() -> None:
    """The ellipse holds every point of the pram's hull and the pusher; its discs hold the ellipse."""
    for radius in (0.35, 0.4, 0.5):
        ahead, length = enclosing_ellipse(radius, carry.PRAM_HULL)
        x = carry.PRAM_HULL[:, 0] - ahead
        assert np.all((x / length) ** 2 + (carry.PRAM_HULL[:, 1] / radius) ** 2 <= 1.0 + 1e-9)
        assert ahead > 0.3 and ahead - length < -0.19 and ahead + length >= carry.PRAM_FRONT
        fp = footprints(np.array([[1.0, 2.0]]), np.array([radius]), np.zeros(1), np.zeros(1), np.array([0.7]),
                        np.array([ahead]), np.array([length]))
        pos, rad, own = covering_discs(fp, np.array([0]))
        assert np.all(own == 0)
        rng = np.random.default_rng(1)
        q = rng.uniform(-1.0, 1.0, (20000, 2))
        q = q[(q ** 2).sum(axis=1) <= 1.0] * [length, radius]
        h = 0.7
        pts = fp.centre[0] + q[:, :1] * [math.cos(h), math.sin(h)] + q[:, 1:] * [-math.sin(h), math.cos(h)]
        assert (np.hypot(*(pts[:, None, :] - pos[None]).transpose(2, 0, 1)) <= rad).any(axis=1).all()


def test_a_pram_pusher_too_narrow_for_its_pram_is_a_scene_error(tmp_path: Path) -> None:
    bad = CORRIDOR.replace('radius = 0.4\npref_speed = 1.0', 'radius = 0.3\npref_speed = 1.0')
    path = tmp_path / "narrow.toml"
    path.write_text(bad)
    with pytest.raises(SceneError, match=r"agents\.profiles\.pram\.radius = 0\.3: must be >= 0\.35 for a "
                                         r"perambulator pusher"):
        load_scene(path)


def test_the_users_pram_is_the_users_footprint(tmp_path: Path) -> None:
    """A user pushing a pram (``[user] carrying``, or a study protocol's ``participant_carrying``) is
    one footprint with it, as an agent pusher is: at least as wide as the pram, reaching ahead. The
    walkers of the corridor keep clear of the pram all the way, and an agent that finds itself in the
    pram's basket (placed there) is out of it after one step, with the user's position untouched."""
    m = _measure("user_pram", 20.0)
    assert m["moved"] > 14.0, m  # the user pushed the pram the corridor's length
    assert m["user_pram"] <= TOL and m["agents"] <= TOL and m["walls"] <= TOL, m
    assert m["user_pram_near"] < 1.0, m  # they did meet it

    path = tmp_path / "user_pram.toml"
    path.write_text(USER_PRAM)
    sim = Simulation(load_scene(path), seed=5)
    c = sim.crowd
    u = int(np.flatnonzero(c.is_user)[0])
    w = int(np.flatnonzero(~c.is_user)[0])
    assert c.radius[u] == pytest.approx(0.35) and c.length[u] > 0.5 and c.ahead[u] > 0.3
    sim.step()
    c = sim.crowd
    h = float(c.heading[u])
    ahead = np.array([math.cos(h), math.sin(h)])
    c.pos[w] = c.pos[u] + 0.9 * ahead  # a walker in the basket
    before = c.pos[u].copy()
    sim.step()
    c = sim.crowd
    h = float(c.heading[u])
    rot = np.array([[math.cos(h), -math.sin(h)], [math.sin(h), math.cos(h)]])
    h_u = _points_support(c.pos[u] + carry.PRAM_HULL @ rot.T)
    assert _penetration(h_u, _DIRS @ c.pos[w] + c.radius[w]) <= TOL
    assert np.hypot(*(c.pos[u] - before)) <= sim.dt * 1.3 + 1e-9  # the user walked on, not pushed


def test_footprints_are_their_definition_row_by_row() -> None:
    """The footprint arrays every step builds (one kernel pass) equal the module's definition in
    numpy, bit for bit: discs, shoulder-turned ellipses, and ellipses reaching ahead (length > 0)."""
    from pedvr.crowd.footprint import DEPTH_RATIO

    rng = np.random.default_rng(3)
    n = 300
    pos = rng.uniform(-10.0, 10.0, (n, 2))
    radius = rng.uniform(0.2, 0.5, n)
    turn = np.where(rng.random(n) < 0.5, rng.uniform(0.0, 1.0, n), 0.0)
    torso = rng.uniform(-np.pi, np.pi, n)
    heading = rng.uniform(-np.pi, np.pi, n)
    length = np.where(rng.random(n) < 0.2, rng.uniform(0.6, 1.0, n), 0.0)
    ahead = np.where(length > 0.0, rng.uniform(0.3, 0.5, n), 0.0)
    fp = footprints(pos, radius, turn, torso, heading, ahead, length)
    rigid = length > 0.0
    c, s = np.cos(heading), np.sin(heading)
    centre = pos + np.where(rigid[:, None], ahead[:, None] * np.stack([c, s], axis=1), 0.0)
    depth = np.where(rigid, radius, radius * (1.0 - turn * (1.0 - DEPTH_RATIO)))
    facing = np.where(rigid[:, None], np.stack([-s, c], axis=1), np.stack([np.cos(torso), np.sin(torso)], axis=1))
    np.testing.assert_array_equal(fp.rigid, rigid)
    np.testing.assert_array_equal(fp.centre, centre)
    np.testing.assert_array_equal(fp.radius, np.where(rigid, length, radius))
    np.testing.assert_array_equal(fp.depth, depth)
    np.testing.assert_allclose(fp.facing, facing, rtol=0.0, atol=1e-15)
