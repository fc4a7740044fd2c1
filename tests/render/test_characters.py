"""The procedural skinned character: mesh properties that no regenerated image can fake (issue 16)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body import JOINTS
from pedvr.body import skeleton as sk
from pedvr.render import bodymesh as bm
from pedvr.render.crowd import (
    SKIN_TONES,
    Blinks,
    Piece,
    agent_looks,
    bind_joints,
    draw_plan,
    in_views,
    lod_levels,
    mesh_pieces,
    pixels_per_radian,
    skin_rows,
)


@pytest.fixture(scope="module")
def character() -> bm.CharacterMesh:
    return bm.procedural_character()


def skinned_world(bones: np.ndarray, dims: np.ndarray, *, level: int = 0) -> np.ndarray:
    """World positions of the always-worn vertices of one agent, skinned on the CPU as crowd.glsl does."""
    mesh = bm.procedural_character().lods[level].vertices
    v = mesh[mesh["variant"] == bm.ALWAYS]
    d = np.asarray(dims, np.float64).reshape(1, 4)
    out = np.zeros((1, 3 * len(JOINTS), 4), np.float32)
    rest = bind_joints(d).astype(np.float32)
    skin_rows(np.ascontiguousarray(bones[None], np.float32), np.zeros(1, np.int64),
              d[:, 3].astype(np.float32), rest, out)
    m = out[0].reshape(len(JOINTS), 3, 4).astype(np.float64)
    p = (v["pos"] + d[0, sk.DIM_SEX] * v["dsex"] + (d[0, sk.DIM_BUILD] - 0.5) * v["dbuild"]).astype(np.float64)
    hp = np.c_[p, np.ones(len(p))]
    world = np.zeros((len(p), 3))
    for k in range(4):
        world += v["weights"][:, k, None] * np.einsum("vij,vj->vi", m[v["bones"][:, k]], hp)
    return world


def test_skin_weights_sum_to_one_over_at_most_four_bones(character: bm.CharacterMesh) -> None:
    for lod in character.lods:
        v = lod.vertices
        assert np.allclose(v["weights"].sum(axis=1), 1.0, atol=1e-5)
        assert (v["weights"] >= 0).all() and v["weights"].shape[1] == 4
        assert (v["bones"] < len(JOINTS)).all()
        # No bone named twice with weight (four distinct influences at most).
        for k in range(4):
            for m in range(k + 1, 4):
                both = (v["weights"][:, k] > 0) & (v["weights"][:, m] > 0)
                assert not (v["bones"][both, k] == v["bones"][both, m]).any()


def test_every_level_of_detail_is_watertight_and_consistently_oriented(character: bm.CharacterMesh) -> None:
    for level, lod in enumerate(character.lods):
        t = lod.triangles.astype(np.int64)
        directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        assert len(np.unique(directed, axis=0)) == len(directed), f"level {level}: a directed edge twice"
        undirected = np.sort(directed, axis=1)
        _, counts = np.unique(undirected, axis=0, return_counts=True)
        assert (counts == 2).all(), f"level {level}: {int((counts != 2).sum())} edges not shared by two faces"
        # Each edge is walked once each way: closed, oriented, no flipped faces.
        rev = {tuple(e) for e in directed[:, ::-1].tolist()}
        assert all(tuple(e) in rev for e in directed[:: max(1, len(directed) // 5000)].tolist())


def test_outward_normals_and_levels_get_cheaper(character: bm.CharacterMesh) -> None:
    counts = character.vertex_counts
    assert len(counts) == bm.LEVELS == len(bm.PROCEDURAL_LOD_ERROR)
    # Each level about halves the one before (the coarsest two differ by the pieces that cannot shrink).
    assert all(1.25 * b < a < 2.8 * b for a, b in zip(counts, counts[1:], strict=False))
    assert counts[0] > 10 * counts[-1]
    v = character.lods[0].vertices
    body = v[(v["variant"] == bm.ALWAYS) & np.isin(v["region"], bm.BODY_REGIONS)]
    centre = np.array([0.0, 0.95, 0.0])
    # Torso vertices' normals point away from the body's axis (no inside-out faces).
    torso = body[(body["pos"][:, 1] > 1.0) & (body["pos"][:, 1] < 1.35) & (np.abs(body["pos"][:, 0]) < 0.12)]
    radial = torso["pos"] - centre
    radial[:, 1] = 0
    assert (np.sum(radial * torso["normal"], axis=1) > 0).mean() > 0.97


def test_limbs_are_round_not_boxes(character: bm.CharacterMesh) -> None:
    """Around the middle of the upper arm and the thigh, surface normals turn continuously (a box
    would show four directions with 90° gaps): no gap over 50° around the limb's axis."""
    v = character.lods[0].vertices
    body = v[v["variant"] == bm.ALWAYS]
    rest = bind_joints(np.array([[1.75, 0.0, 0.5, 1.0]]))[0]
    for a, b in (("LShoulder", "LElbow"), ("LHip", "LKnee"), ("RElbow", "RWrist")):
        pa, pb = rest[JOINTS.index(a)], rest[JOINTS.index(b)]
        e = (pb - pa) / np.linalg.norm(pb - pa)
        s = (body["pos"] - pa) @ e / np.linalg.norm(pb - pa)
        near = np.linalg.norm(np.cross(body["pos"] - pa, e), axis=1) < 0.12
        ring = body[(s > 0.4) & (s < 0.6) & near]
        n = ring["normal"] - np.outer(ring["normal"] @ e, e)
        ang = np.sort(np.degrees(np.arctan2(n[:, 2], n[:, 0])))
        gaps = np.diff(np.r_[ang, ang[0] + 360.0])
        assert len(ring) > 24 and gaps.max() < 50.0, f"{a}->{b}: {len(ring)} vertices, gap {gaps.max():.0f} deg"


def test_hands_have_a_thumb_and_the_face_has_a_nose_and_eyes(character: bm.CharacterMesh) -> None:
    v = character.lods[0].vertices
    body = v[(v["variant"] == bm.ALWAYS) & np.isin(v["region"], bm.BODY_REGIONS)]
    p = body["pos"]
    wrist = bind_joints(np.array([[1.75, 0.0, 0.5, 1.0]]))[0, JOINTS.index("LWrist")]
    hand = p[(np.linalg.norm(p - wrist, axis=1) < 0.2) & (p[:, 1] < wrist[1]) & (p[:, 0] > 0.15)]
    # The thumb reaches forward of the palm and fingers block (which are about 7 cm deep).
    assert hand[:, 2].max() - wrist[2] > 0.06
    face = p[(p[:, 1] > 1.58) & (p[:, 1] < 1.66) & (np.abs(p[:, 0]) < 0.01)]
    assert face[:, 2].max() > 0.125  # the nose tip stands out of the face (~0.1 m)
    eyes = v[v["region"] == bm.EYE]
    assert len(eyes) > 50 and {JOINTS[b] for b in np.unique(eyes["bones"][:, 0])} == {"LEye", "REye"}
    assert np.allclose(eyes["weights"][:, 0], 1.0)  # eyeballs turn rigidly with the eye joints


def test_shape_offsets_follow_sex_and_build(character: bm.CharacterMesh) -> None:
    v = character.lods[0].vertices
    body = v[(v["variant"] == bm.ALWAYS) & np.isin(v["region"], bm.BODY_REGIONS)]
    p = body["pos"]
    chest = (p[:, 1] > 1.25) & (p[:, 1] < 1.35) & (p[:, 2] > 0.05) & (np.abs(p[:, 0]) < 0.08)
    assert body["dsex"][chest, 2].max() > 0.015  # breasts
    waist = (p[:, 1] > 1.08) & (p[:, 1] < 1.15) & (np.abs(p[:, 0]) < 0.13)
    assert (np.sum(body["dbuild"][waist] * body["normal"][waist], axis=1) > 0).mean() > 0.9  # heavier: wider
    head = p[:, 1] > 1.6
    assert np.abs(body["dsex"][head]).max() < 0.01  # heads are shared


@pytest.mark.parametrize("sex,build", [(0.0, 0.0), (1.0, 1.0), (1.0, 0.2)])
def test_bind_pose_skinning_reproduces_the_shape(sex: float, build: float) -> None:
    dims = np.array([1.75, sex, build, 1.0])
    bones = np.zeros((len(JOINTS), 4, 4), np.float32)
    bones[:, :3, :3] = np.eye(3)
    bones[:, 3, 3] = 1.0
    bones[:, :3, 3] = bind_joints(dims[None])[0]
    world = skinned_world(bones, dims)
    v = bm.procedural_character().lods[0].vertices
    v = v[v["variant"] == bm.ALWAYS]
    expect = v["pos"] + sex * v["dsex"] + (build - 0.5) * v["dbuild"]
    assert np.abs(world - expect).max() < 1e-4


def test_skin_tones_span_the_monk_scale_and_looks_are_stable() -> None:
    ids = np.arange(2000)
    dims = np.zeros((2000, 4))
    dims[:, 1] = ids % 2
    a, b = agent_looks(ids, dims), agent_looks(ids, dims)
    assert np.array_equal(a.skin, b.skin) and np.array_equal(a.hair_style, b.hair_style)
    assert set(np.unique(a.tone)) == set(range(len(SKIN_TONES)))
    assert np.bincount(a.tone).min() > 120  # every tone common, none rare
    assert not a.skirt[dims[:, 1] == 0].any() and a.skirt[dims[:, 1] == 1].mean() > 0.2
    assert len(np.unique(a.hair_style)) == len(bm.HAIR_STYLES)


def test_blinks_come_15_to_20_times_a_minute_and_with_gaze_shifts() -> None:
    b = Blinks()
    ids = np.arange(40)
    fwd = np.tile([0.0, 0.0, 1.0], (40, 1))
    starts = np.zeros(40)
    prev = np.zeros(40)
    for k in range(1, 60 * 60):
        c = b.update(ids, k / 60.0, fwd)
        starts += (c > 0) & (prev == 0)
        prev = c
    rate = starts.mean()  # per minute
    assert 15.0 <= rate <= 20.0, rate
    b2 = Blinks()
    b2.update(ids[:1], 0.0, fwd[:1])
    assert b2.update(ids[:1], 0.3, fwd[:1])[0] == 0.0
    turned = np.array([[math.sin(0.5), 0.0, math.cos(0.5)]])  # a 29° saccade within one frame
    closures = [b2.update(ids[:1], 0.3 + k / 90.0, turned)[0] for k in range(1, 12)]
    assert max(closures) == 1.0


def test_levels_of_detail_follow_what_they_change_on_screen() -> None:
    """A level serves where its deviation from level 0 subtends at most LOD_TOLERANCE_PX (1 px)."""
    errors = (0.0, 0.003, 0.006, 0.012)
    ppr = pixels_per_radian(np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, -1, -0.2], [0, 0, -1, 0]]), 1000)
    assert ppr == 500.0  # a 90° view 1000 pixels high: 500 pixels per radian at its centre
    # Level 1 from 1.5 m, level 2 from 3 m, level 3 from 6 m.
    pos = np.array([[1.4, 0.0], [0.0, 1.6], [2.9, 0.0], [3.1, 0.0], [-5.9, 0.0], [6.1, 0.0], [60.0, 0.0]])
    assert lod_levels(pos, np.zeros(2), pixels_per_radian=ppr, errors=errors).tolist() == [0, 1, 1, 2, 2, 3, 3]
    # Twice the pixels: twice the distances; a finer level never serves beyond a coarser one.
    assert lod_levels(pos, np.zeros(2), pixels_per_radian=2 * ppr, errors=errors).tolist() == [0, 0, 0, 1, 1, 2, 3]
    assert lod_levels(pos, np.zeros(2), pixels_per_radian=ppr, errors=(0.0, 0.006, 0.003)).tolist() == \
        [0, 0, 0, 2, 2, 2, 2]


def test_mesh_pieces_order_triangles_by_variant() -> None:
    variant = np.array([-1, -1, -1, 0, 0, 0, 10, 10, 10, 1, 1, 1])
    tris = np.array([[3, 4, 5], [0, 1, 2], [6, 7, 8], [0, 2, 1], [9, 10, 11]])
    t, pieces = mesh_pieces(tris, variant)
    assert t.tolist() == [[0, 1, 2], [0, 2, 1], [3, 4, 5], [9, 10, 11], [6, 7, 8]]
    assert pieces == (Piece(-1, 0, 6, 3), Piece(0, 6, 3, 3), Piece(1, 9, 3, 3), Piece(10, 12, 3, 3))
    with pytest.raises(ValueError, match=r"triangle 0 joins vertices of variants \[-1, 0\]"):
        mesh_pieces(np.array([[0, 1, 3]]), variant)


def test_draw_plan_gives_each_agent_the_pieces_it_wears_and_only_those() -> None:
    rng = np.random.default_rng(3)
    n, styles = 200, 3
    pieces = [[(Piece(-1, 0, 30, 10), Piece(0, 30, 6, 4), Piece(1, 36, 6, 4), Piece(2, 42, 6, 4),
                Piece(10, 48, 9, 5))] * 2, [(Piece(-1, 0, 12, 6),)] * 2]
    char, lod = rng.integers(0, 2, n), rng.integers(0, 2, n)
    style, skirt = rng.integers(0, styles, n), rng.random(n) < 0.3
    order, draws = draw_plan(char, lod, style, skirt, pieces, always=-1, skirt_variant=10)
    drawn: dict[int, list[tuple[int, int, int]]] = {a: [] for a in range(n)}
    for d in draws:
        for a in order[d.row, d.first:d.first + d.count]:
            drawn[int(a)].append((d.character, d.level, pieces[d.character][d.level][d.piece].variant))
    for a in range(n):
        c, level = int(char[a]), int(lod[a])
        want = [(c, level, -1)]
        if c == 0:
            want += [(c, level, int(style[a]))] + ([(c, level, 10)] if skirt[a] else [])
        assert sorted(drawn[a]) == sorted(want), a
    # One draw per character, level and piece someone wears, whatever the number of agents.
    assert len(draws) == 2 * 5 + 2 * 1
    _, few = draw_plan(char[:3], lod[:3], style[:3], skirt[:3], pieces, always=-1, skirt_variant=10)
    assert len(few) <= len(draws)


def test_procedural_levels_deviations_are_the_ones_written_down(character: bm.CharacterMesh) -> None:
    """PROCEDURAL_LOD_ERROR (measured at 1.5 mm) against a coarser measurement here (3 mm, seconds):
    each measurement is within 0.58 of its spacing of the surfaces' true distance."""
    measured = bm.lod_deviation(character.lods, spacing=0.003)
    assert measured[0] == 0.0 and bm.PROCEDURAL_LOD_ERROR[0] == 0.0
    assert np.allclose(measured, bm.PROCEDURAL_LOD_ERROR, atol=0.58 * (0.003 + 0.0015))
    assert all(a < b for a, b in zip(measured, measured[1:], strict=False))  # each level deviates more


def test_in_views_keeps_every_agent_whose_body_may_show() -> None:
    from pedvr.render.math3d import first_person_eye

    eye = first_person_eye(pos=np.zeros(2), heading=0.0, aspect=1.0)  # 70° each way, looking down +x
    vp = [eye.view_projection]
    half = math.radians(35.0)
    # Ahead; behind; beside; beyond the side edge by less than a body's reach; by more; past the far plane.
    edge = np.array([math.cos(half), math.sin(half)])
    out = np.array([-math.sin(half), math.cos(half)])  # outward, perpendicular to the left edge
    pos = np.array([[5.0, 0.0], [-3.0, 0.0], [0.0, 4.0], 6.0 * edge + 1.4 * out, 6.0 * edge + 2.0 * out,
                    [5000.0, 0.0]])
    assert in_views(pos, np.ones(len(pos)), vp).tolist() == [True, False, False, True, False, False]
    # A taller agent's sphere is larger; a second view adds what it sees.
    assert in_views(pos[4:5], np.array([1.5]), vp).tolist() == [True]
    back = first_person_eye(pos=np.zeros(2), heading=math.pi, aspect=1.0)
    assert in_views(pos, np.ones(len(pos)), [*vp, back.view_projection]).tolist()[:2] == [True, True]


def test_lod_deviation_is_a_hausdorff_distance_and_caps_its_points(monkeypatch: pytest.MonkeyPatch) -> None:
    """A square and the same square 5 cm above it deviate by 5 cm; with ``max_points`` a mesh of
    large triangles is sampled more coarsely (a boxy avatar took 90 s at 3 mm), not more wrongly."""
    def square(y: float) -> bm.MeshLOD:
        v = np.zeros(4, bm.VERTEX_DTYPE)
        v["pos"] = [[0, y, 0], [1, y, 0], [1, y, 1], [0, y, 1]]
        v["variant"] = bm.ALWAYS
        return bm.MeshLOD(vertices=v, triangles=np.array([[0, 1, 2], [0, 2, 3]], np.uint32))

    sizes: list[int] = []
    real = bm._surface_points
    monkeypatch.setattr(bm, "_surface_points", lambda v, t, s: sizes.append(len(p := real(v, t, s))) or p)
    assert bm.lod_deviation([square(0.0), square(0.05)], spacing=0.01) == pytest.approx((0.0, 0.05))
    assert max(sizes) > 10_000
    sizes.clear()
    assert bm.lod_deviation([square(0.0), square(0.05)], spacing=0.001, max_points=2000) == pytest.approx((0.0, 0.05))
    assert max(sizes) < 2 * 2000  # about max_points: the estimate from the area undercounts by up to 2
