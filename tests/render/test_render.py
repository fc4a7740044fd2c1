"""Offscreen EGL renders at small sizes: properties of pixels (STYLE.md habit 9)."""

from __future__ import annotations

import dataclasses
import math

import moderngl
import numpy as np
import pytest

from pedvr.body import JOINTS
from pedvr.body import skeleton as sk
from pedvr.render import bodymesh as bm
from pedvr.render.math3d import EyeView, desktop_stereo_eyes, first_person_eye, first_person_rotation, project
from pedvr.render.overhead import USER
from pedvr.render.renderer import TARGET_ALPHA, OffscreenTarget, Renderer
from pedvr.render.snapshot import SPHERE_HEIGHT, TARGET_RADIUS, Snapshot
from pedvr.render.text import Hud
from tests.render.conftest import posed

W, H = 96, 64
D = 2.2  # m in front of the camera


def render(
    renderer: Renderer,
    snap: Snapshot,
    eyes: list[EyeView],
    *,
    size: tuple[int, int] = (W, H),
) -> np.ndarray:
    t = OffscreenTarget(renderer.ctx, size)
    renderer.begin_frame()
    renderer.update(snap)
    renderer.draw_scene(eyes, framebuffer=t.fbo)
    img = t.read().astype(np.int32)
    t.release()
    return img


def nobody() -> Snapshot:
    return Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0))


def one_agent(x: float, *, heading: float = math.pi, y: float = 0.0) -> Snapshot:
    return Snapshot.of_agents(pos=[[x, y]], heading=[heading], ids=[3])


def changed(a: np.ndarray, b: np.ndarray, *, threshold: int = 12) -> np.ndarray:
    return np.abs(a - b).max(axis=2) > threshold


def test_a_character_in_front_covers_the_pixels_its_body_projects_to(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    empty = render(renderer, nobody(), [eye])
    snap, body = posed([[D, 0.0]], [math.pi])  # the body layer's pose: standing, facing the camera
    img = render(renderer, snap, [eye])
    mask = changed(img, empty)
    rows, cols = np.nonzero(mask)
    assert mask.sum() > 150
    # The body spans the projected feet (floor) to the top of the head, about its width, centred.
    head_top = body.state.world_pos[0, sk.HEAD_TOP]
    assert head_top[1] == pytest.approx(body.state.dims[0, sk.DIM_HEIGHT], abs=0.03)
    top = project(eye.view_projection, head_top, width=W, height=H)
    feet = project(eye.view_projection, np.array([D, 0.0, 0.0]), width=W, height=H)
    half_w = project(eye.view_projection, np.array([D, 1.0, 0.35]), width=W, height=H)[0] - W / 2
    assert rows.min() == pytest.approx(top[1], abs=2.5)
    assert rows.max() == pytest.approx(feet[1], abs=3.5)  # contact shadow reaches a little further
    assert abs(cols.mean() - W / 2) < 2.0
    assert cols.max() - cols.min() < 2 * half_w + 4
    # Inside the body's box most pixels changed: it is a person, not a wire frame.
    box = mask[int(top[1]) + 1 : int(feet[1]) - 1, int(W / 2 - half_w / 2) : int(W / 2 + half_w / 2)]
    assert box.mean() > 0.6


def test_the_user_body_is_hidden_in_first_person(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    snap, _ = posed([[0.0, 0.0], [3.0, 0.0]], [0.0, math.pi], is_user=np.array([True, False]))
    assert snap.bones is not None and snap.dims is not None
    others = Snapshot.of_agents(
        pos=snap.pos[1:], heading=snap.heading[1:], ids=snap.ids[1:], bones=snap.bones[1:], dims=snap.dims[1:]
    )
    with_user = render(renderer, snap, [eye])
    without = render(renderer, others, [eye])
    assert not changed(with_user, without).any()
    assert renderer.stats.agents_drawn == 1


def _centroid_x(mask: np.ndarray) -> float:
    return float(np.nonzero(mask)[1].mean())


def test_stereo_disparity_is_positive_and_larger_for_near_objects(renderer: Renderer) -> None:
    w, h = 160, 96
    eyes = list(desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=w / h, ipd=0.063))
    empty = [render(renderer, nobody(), [e], size=(w, h)) for e in eyes]
    disparity = {}
    for dist in (1.5, 6.0):
        imgs = [render(renderer, one_agent(dist), [e], size=(w, h)) for e in eyes]
        xl, xr = (_centroid_x(changed(i, e)) for i, e in zip(imgs, empty, strict=True))
        disparity[dist] = xl - xr
        # Closed form for parallel eyes: f * ipd / z pixels, f = (w / 2) / tan(hfov / 2).
        f = (w / 2) * eyes[0].projection[0, 0]
        assert disparity[dist] == pytest.approx(f * 0.063 / dist, abs=1.0)
    assert disparity[1.5] > disparity[6.0] > 0


def test_side_by_side_single_pass_equals_two_passes(renderer: Renderer) -> None:
    w, h = 80, 64
    snap, _ = posed(
        [[3.0, 0.3], [5.0, -1.0], [7.0, 1.5]],
        [math.pi, 2.0, 0.2],
        vel=[[-0.8, 0.0], [0.0, 0.0], [1.0, 0.2]],
        sphere=np.array([4.0, 0.5]),
    )
    eyes = list(desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=w / h))
    single = render(renderer, snap, eyes, size=(2 * w, h))
    for k, eye in enumerate(eyes):
        alone = render(renderer, snap, [eye], size=(w, h))
        half = single[:, k * w : (k + 1) * w]
        differ = np.abs(half - alone).max(axis=2) > 24
        assert differ.mean() < 0.01, f"eye {k}: {differ.mean():.3%} of pixels differ"
    both = renderer.stats.draw_calls
    render(renderer, snap, eyes[:1], size=(w, h))
    assert renderer.stats.draw_calls == both  # both eyes in each call: no call per eye


EYE_H = 1.64  # m: the reference body's eye height
FACE_ID = 16  # an id whose looks give medium-dark skin (Monk tone 7), so eye whites stand out from skin


def _face(renderer: Renderer, gaze: tuple[float, float, float], *, size: tuple[int, int] = (240, 180),
          dist: float = 0.55, fovy: float = 30.0) -> np.ndarray:
    """An agent ``dist`` in front of the camera, facing it, its gaze controller aimed at ``gaze``."""
    w, h = size
    snap, _ = posed([[dist, 0.0]], [math.pi], seconds=1.5, gaze={0: gaze}, reference=True)
    snap = dataclasses.replace(snap, ids=np.array([FACE_ID]))
    return _render_face(renderer, snap, size=size, fovy=fovy)


def _render_face(renderer: Renderer, snap: Snapshot, *, size: tuple[int, int], fovy: float) -> np.ndarray:
    """The agent's pixels (elsewhere -1: the empty scene is subtracted)."""
    w, h = size
    cam = EyeView.from_pose(
        rotation=first_person_rotation(0.0),
        position=np.array([0.0, EYE_H, 0.0]),
        projection=first_person_eye(
            pos=np.zeros(2), heading=0.0, fovy=math.radians(fovy), aspect=w / h
        ).projection,
    )
    img = render(renderer, snap, [cam], size=(w, h))
    empty = render(renderer, nobody(), [cam], size=(w, h))
    img[~changed(img, empty, threshold=2)] = -1
    return img


def _irises(img: np.ndarray, *, bright: int = 140) -> list[tuple[float, int, int]]:
    """Per visible eye (left to right in the image): where its iris sits between the whites,
    -1 (against the image-left corner) .. +1 (image-right), and the white and iris pixel counts.

    Whites: bright, unsaturated pixels; the iris: dark pixels on the rows of the whites, between
    the leftmost and rightmost white pixel of that eye.
    """
    white = (img.min(axis=2) > bright) & (np.ptp(img, axis=2) < 40)
    rows, cols = np.nonzero(white)
    assert rows.size >= 4, "no eye whites visible"
    mid = img.shape[1] / 2
    out = []
    for side in (cols < mid, cols >= mid):
        r, c = rows[side], cols[side]
        if r.size < 3:
            continue
        box = img[r.min() : r.max() + 1, c.min() : c.max() + 1]
        dark = box.max(axis=2) < 110
        _, ic = np.nonzero(dark)
        if ic.size == 0:
            out.append((float("nan"), int(r.size), 0))
            continue
        iris = ic.mean() + c.min()
        left, right = (c < iris).sum(), (c > iris).sum()
        out.append((float((left - right) / (left + right)), int(r.size), int(ic.size)))
    return out


BLUE_EYED = 39  # an id whose looks give blue irises and a mid skin tone (Monk 6)


def _iris_on_pixels(renderer: Renderer, gaze: tuple[float, float, float]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per eye: the blue iris pixels' centroid, the projected eye centre and the projected point
    where the eye's axis leaves the eyeball (what the body layer says the eye looks along)."""
    w, h, fovy = 360, 270, 30.0
    snap, body = posed([[0.55, 0.0]], [math.pi], seconds=1.5, gaze={0: gaze}, reference=True)
    snap = dataclasses.replace(snap, ids=np.array([BLUE_EYED]))
    img = _render_face(renderer, snap, size=(w, h), fovy=fovy)
    proj = first_person_eye(pos=np.zeros(2), heading=0.0, fovy=math.radians(fovy), aspect=w / h).projection
    cam = EyeView.from_pose(rotation=first_person_rotation(0.0), position=np.array([0.0, EYE_H, 0.0]),
                            projection=proj)
    blue = (img[:, :, 2] > img[:, :, 0] + 12) & (img[:, :, 2] > img[:, :, 1]) & (img.min(axis=2) >= 0)
    assert snap.bones is not None
    out = []
    for j in (sk.L_EYE, sk.R_EYE):
        m = snap.bones[0, j].astype(np.float64)
        centre = project(cam.view_projection, m[:3, 3], width=w, height=h)
        axis = project(cam.view_projection, m[:3, 3] + m[:3, 2] * bm.EYE_RADIUS, width=w, height=h)
        rows, cols = np.nonzero(blue)
        near = np.hypot(cols - centre[0], rows - centre[1]) < 12
        assert near.sum() >= 20, f"eye {JOINTS[j]}: {int(near.sum())} iris pixels"
        out.append((np.array([cols[near].mean(), rows[near].mean()]) + 0.5, centre, axis))
    return out


def test_the_irises_on_pixels_follow_the_eyes_and_centre_when_gazing_at_the_camera(renderer: Renderer) -> None:
    """Iris position on rendered pixels (issue 16): the iris drawn is where the body's eye joint
    points, within a pixel (at ~7 px iris radius); gazing at the camera it is centred on the eye."""
    at_camera = _iris_on_pixels(renderer, (0.0, EYE_H, 0.0))
    for iris, centre, axis in at_camera:
        assert abs(iris[0] - axis[0]) < 1.0
        assert abs(iris[0] - centre[0]) < 1.0  # looking at us: iris over the eye's centre
    for side, target in ((+1, (-0.45, EYE_H, 0.3)), (-1, (-0.45, EYE_H, -0.3))):
        aside = _iris_on_pixels(renderer, target)
        for iris, centre, axis in aside:
            assert abs(iris[0] - axis[0]) < 1.0
            # The agent's left is image-right (math3d's chirality note).
            assert side * (iris[0] - centre[0]) > 2.0, (side, iris, centre)


def test_eyes_are_readable_at_2_m_at_1280x720(renderer: Renderer) -> None:
    """At 2 m in a 1280×720, 70° view (the desktop window) both eyes show white and a dark iris."""
    img = _face(renderer, (0.0, EYE_H, 0.0), size=(1280, 720), dist=2.0, fovy=70.0)
    eyes = _irises(img, bright=120)
    assert len(eyes) == 2
    for _, whites, iris in eyes:
        assert whites >= 3 and iris >= 2, eyes


def test_a_blink_hides_the_eyes(renderer: Renderer) -> None:
    open_ = _face(renderer, (0.0, EYE_H, 0.0))
    renderer._blinks.closure = lambda age: np.ones_like(age)  # type: ignore[method-assign]
    try:
        shut = _face(renderer, (0.0, EYE_H, 0.0))
    finally:
        del renderer._blinks.closure
    white = lambda img: ((img.min(axis=2) > 140) & (np.ptp(img, axis=2) < 40)).sum()  # noqa: E731
    assert white(open_) > 40 and white(shut) < 0.1 * white(open_)


def test_the_red_target_is_small_at_chest_height_and_see_through_over_a_pedestrian(renderer: Renderer) -> None:
    """Issue 16: the route target floats at chest height, 22 cm across; over the background it is
    red, in front of a pedestrian it lets the pedestrian show through."""
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=SPHERE_HEIGHT, aspect=W / H)
    alone = render(renderer, Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0),
                                                sphere=np.array([1.5, 0.0])), [eye])
    c = alone[H // 2, W // 2]
    assert c[0] > 150 and c[1] < 70 and c[2] < 70
    top = project(eye.view_projection, np.array([1.5, SPHERE_HEIGHT + TARGET_RADIUS, 0.0]), width=W, height=H)
    red = (alone[:, :, 0] > 120) & (alone[:, :, 1] < 70)
    assert abs(np.nonzero(red[:, W // 2])[0].min() - top[1]) <= 1.5
    snap, _ = posed([[3.0, 0.0]], [math.pi], reference=True)
    behind = render(renderer, dataclasses.replace(snap, sphere=np.array([1.5, 0.0])), [eye])
    person = render(renderer, snap, [eye])
    mix = behind[H // 2, W // 2].astype(float)
    expect = TARGET_ALPHA * c + (1 - TARGET_ALPHA) * person[H // 2, W // 2]
    assert np.abs(mix - expect).max() < 40  # a blend: the pedestrian shows through the target
    assert np.abs(mix - c).max() > 40


def test_draw_calls_do_not_grow_with_the_crowd(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, aspect=W / H)
    counts = []
    rng = np.random.default_rng(1)
    for n in (40, 300, 1000):
        ang, rad = rng.uniform(-0.5, 0.5, n), rng.uniform(2.0, 30.0, n)
        pos = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
        render(renderer, Snapshot.of_agents(pos=pos, heading=np.zeros(n)), [eye])
        counts.append(renderer.stats.draw_calls)
    # 64 pixels high, everyone is at the coarsest level (crowd.lod_levels). Floor and solids; in the
    # view and in the shadow map one crowd draw per piece of the mesh worn (the body, each hair
    # style, the skirt); the solids' shadow; the contact shadows.
    assert renderer.stats.lod_agents == (0,) * (bm.LEVELS - 1) + (1000,)
    assert counts[0] == counts[1] == counts[2] == 2 + 2 * (1 + len(bm.HAIR_STYLES) + 1) + 1 + 1


def test_each_agent_runs_the_vertices_of_its_level_and_worn_pieces_only(renderer: Renderer) -> None:
    """Crowd vertices per frame (issue 27): the view's level for the agent's distance and the view's
    pixels, the shadow map's coarsest level, and in both only the hair style and skirt it wears."""
    from pedvr.render.crowd import agent_looks, lod_levels, mesh_pieces, pixels_per_radian
    from pedvr.render.figures import default_dims

    mesh = bm.procedural_character()
    w, h = 160, 720
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, aspect=w / h)
    levels = []
    for x in (1.5, 6.0, 14.0, 40.0):
        snap = one_agent(x)
        render(renderer, snap, [eye], size=(w, h))
        level = int(lod_levels(np.array([[x, 0.0]]), np.zeros(2), pixels_per_radian=pixels_per_radian(
            eye.projection, h), errors=bm.PROCEDURAL_LOD_ERROR)[0])
        assert renderer.stats.lod_agents[level] == 1
        levels.append(level)
        looks = agent_looks(snap.ids, default_dims(snap.ids))
        worn = {bm.ALWAYS, int(looks.hair_style[0])} | ({bm.SKIRT_VARIANT} if looks.skirt[0] else set())

        def vertices(lod: bm.MeshLOD, worn: set[int] = worn) -> int:
            return sum(p.vertices for p in mesh_pieces(lod.triangles, lod.vertices["variant"])[1] if p.variant in worn)

        # The shadow map covers 16 m around the viewer (lighting.SHADOW_HALF_EXTENT): nobody at 40 m casts in it.
        shadow = vertices(mesh.lods[-1]) if x < 16.0 else 0
        assert renderer.stats.vertices == vertices(mesh.lods[level]) + shadow
        assert vertices(mesh.lods[level]) < mesh.vertex_counts[level]  # not the styles it does not wear
    assert levels[0] == 0 and levels[-1] == bm.LEVELS - 1 and levels == sorted(levels)


def test_overhead_view_shows_the_user_in_blue_where_it_stands(
    ctx: moderngl.Context, renderer: Renderer
) -> None:
    from pedvr.render.math3d import overhead_transform

    w, h = 192, 128
    t = OffscreenTarget(ctx, (w, h))
    snap = Snapshot.of_agents(
        pos=[[5.0, 8.0], [-6.0, -4.0]],
        heading=[0.0, 1.0],
        radius=1.0,
        is_user=np.array([True, False]),
        gaze_target=np.array([[np.nan] * 3, [5.0, 1.6, 8.0]]),
    )
    renderer.update(snap)
    renderer.draw_overhead(framebuffer=t.fbo, center=(0.0, 0.0), extent=24.0)
    img = t.read().astype(int)
    m = overhead_transform(center=(0.0, 0.0), extent=24.0, aspect=w / h)
    for (x, y), colour in (((5.0, 8.0), np.array(USER[:3]) * 255), ((-6.0, -4.0), None)):
        ndc = m @ [x, y - 0.5, 1.0]  # off the heading ticks (toward +x and +y here)
        col, row = int((ndc[0] + 1) / 2 * w), int((1 - ndc[1]) / 2 * h)
        if colour is not None:
            assert np.abs(img[row, col] - colour).max() < 20
        else:
            assert np.ptp(img[row, col]) < 20 and img[row, col].mean() < 200  # a grey agent disc
    # 2D +y is down the screen (a true view from above): the user (y = 8) is in the lower half.
    ndc_user = m @ [5.0, 8.0, 1.0]
    assert ndc_user[1] < 0
    t.release()


def test_hud_panel_is_drawn_top_left(ctx: moderngl.Context, renderer: Renderer) -> None:
    t = OffscreenTarget(ctx, (W, H))
    t.fbo.clear(1.0, 1.0, 1.0, 1.0)
    hud = Hud(label="B", fps=90.0, frame_ms=11.1)
    renderer.draw_panel(hud.image(font_size=10), framebuffer=t.fbo, x=2, y=2)
    img = t.read().astype(int)
    assert img[4, 4].max() < 200 and img[H - 2, W - 2].min() > 250
    assert hud.lines() == [" 90.0 fps   11.1 ms", "condition B"]


def test_a_standing_character_casts_a_shadow_on_the_floor(ctx: moderngl.Context, renderer: Renderer) -> None:
    """The key light's shadow (issue 16): floor pixels beside the feet, on the side away from the
    light, are darker with the shadow map than without; floor on the lit side is unchanged."""
    from tests.render.conftest import EMPTY

    w, h = 160, 120
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, pitch=-0.35, eye_height=1.6, aspect=w / h)
    snap, _ = posed([[3.0, 0.0]], [math.pi], reference=True)
    unshadowed = Renderer(ctx, world=EMPTY, shadows=False)
    try:
        with_map, without = render(renderer, snap, [eye], size=(w, h)), render(unshadowed, snap, [eye], size=(w, h))
    finally:
        unshadowed.release()
    sun = np.array([0.35, 0.45]) / np.hypot(0.35, 0.45)  # the light's direction on the ground (x, y)
    lum = lambda img, p: float(img[int(p[1]) - 1 : int(p[1]) + 2, int(p[0]) - 1 : int(p[0]) + 2].mean())  # noqa: E731
    for d in (0.55, 0.8):
        shade = project(eye.view_projection, np.array([3.0 - sun[0] * d, 0.0, -sun[1] * d]), width=w, height=h)
        assert lum(with_map, shade) < 0.75 * lum(without, shade), d
    lit = project(eye.view_projection, np.array([3.0 + sun[0] * 0.7, 0.0, sun[1] * 0.7]), width=w, height=h)
    assert abs(lum(with_map, lit) - lum(without, lit)) < 3


def _lightness(rgb: np.ndarray) -> float:
    """CIE L* of an sRGB colour (0-255)."""
    c = np.asarray(rgb, np.float64) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    y = float(lin @ [0.2126, 0.7152, 0.0722])
    return 116.0 * (y ** (1 / 3) if y > 0.008856 else 7.787 * y + 16 / 116) - 16.0


def test_skin_tones_read_from_light_to_dark_on_rendered_faces(renderer: Renderer) -> None:
    """Measured on a rendered frame (issue 16): faces of the ten Monk tones, lit as the crowd is,
    keep their order and span a wide range of lightness (the lightest not read as brown)."""
    from pedvr.render.crowd import SKIN_TONES, agent_looks

    pool = np.arange(400)
    tones = agent_looks(pool, sk.user_dims(len(pool))).tone
    ids = np.array([pool[tones == k][0] for k in range(len(SKIN_TONES))])
    n = len(ids)
    ys = (np.arange(n) - (n - 1) / 2) * 0.45
    snap, body = posed(np.stack([np.full(n, 3.2), ys], axis=1), np.full(n, math.pi), reference=True)
    snap = dataclasses.replace(snap, ids=ids)
    w, h = 960, 240
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=w / h, fovy=math.radians(30))
    img = render(renderer, snap, [eye], size=(w, h))
    head = body.state.world_pos[:, sk.HEAD]
    lightness = []
    for i in range(n):
        cheek = head[i] + np.array([-0.09, 0.0, 0.04])  # on a cheek, facing the camera
        c, r = project(eye.view_projection, cheek, width=w, height=h)
        patch = img[int(r) - 1 : int(r) + 2, int(c) - 1 : int(c) + 2].reshape(-1, 3)
        lightness.append(_lightness(np.median(patch, axis=0)))
    # In the shade of the key light (faces toward the camera, away from the light): lightest and
    # darkest as a person would read them, the order kept, lightness tracking the tones' own. (The
    # skin's sheen, which shows the darkest faces' shape, lifts their shaded cheeks by about 4 L*:
    # issue 25 item 16, test_looks.py.)
    albedo = [_lightness(255 * np.where(t <= 0.0031308, 12.92 * t, 1.055 * t ** (1 / 2.4) - 0.055))
              for t in SKIN_TONES]
    assert lightness[0] > 55 and lightness[-1] < 28, lightness
    assert np.corrcoef(albedo, lightness)[0, 1] > 0.97, (albedo, lightness)
    assert np.ptp(lightness) > 30
    assert sum(b > a + 1 for a, b in zip(lightness, lightness[1:], strict=False)) <= 1, lightness


def test_multisampled_targets_smooth_edges_and_resolve_on_read(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    snap, _ = posed([[2.5, 0.0]], [math.pi], reference=True)
    images = []
    for samples in (0, 4):
        t = OffscreenTarget(renderer.ctx, (W, H), samples=samples)
        renderer.update(snap)
        renderer.draw_scene([eye], framebuffer=t.fbo)
        images.append(t.read().astype(int))
        t.release()
    plain, msaa = images
    assert np.abs(plain - msaa).mean() < 4.0  # the same picture...
    edges = lambda img: len(np.unique(img.reshape(-1, 3), axis=0))  # noqa: E731
    assert edges(msaa) > 1.1 * edges(plain)  # ...with blended edge pixels (1.0 without multisampling)


def test_agents_out_of_view_are_not_drawn_and_culling_changes_no_pixel(
    renderer: Renderer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Frustum culling (issue 27, crowd.in_views): agents behind the user or far to the side run no
    vertex in the view, and the pixels are the same as drawing everyone (walking bodies across
    the view's edges, both eyes side by side)."""
    import pedvr.render.renderer as rmod

    w, h = 120, 96
    rng = np.random.default_rng(7)
    ang = np.concatenate([np.linspace(-math.pi, math.pi, 24, endpoint=False), rng.uniform(-0.9, 0.9, 24)])
    rad = np.concatenate([np.full(24, 2.5), rng.uniform(0.8, 9.0, 24)])
    pos = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
    snap, _ = posed(pos, rng.uniform(-math.pi, math.pi, len(pos)), vel=rng.normal(0.0, 0.8, (len(pos), 2)))
    eyes = list(desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=w / h))
    culled = render(renderer, snap, eyes, size=(2 * w, h))
    seen = sum(renderer.stats.lod_agents)
    assert 10 < seen < len(pos) - 10
    monkeypatch.setattr(rmod, "in_views", lambda p, s, m: np.ones(len(p), np.bool_))
    everyone = render(renderer, snap, eyes, size=(2 * w, h))
    assert sum(renderer.stats.lod_agents) == len(pos)
    assert np.array_equal(culled, everyone)
