"""Offscreen EGL renders at small sizes: properties of pixels (STYLE.md habit 9)."""

from __future__ import annotations

import math

import moderngl
import numpy as np
import pytest

from pedvr.body import skeleton as sk
from pedvr.render.math3d import EyeView, desktop_stereo_eyes, first_person_eye, first_person_rotation, project
from pedvr.render.overhead import USER
from pedvr.render.renderer import OffscreenTarget, Renderer
from pedvr.render.snapshot import Snapshot
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
    assert renderer.stats.draw_calls == 5  # floor, obstacles, sphere, crowd, shadows: both eyes in each call


EYE_H = 1.64  # m: the reference body's eye height


def _face(renderer: Renderer, gaze: tuple[float, float, float]) -> np.ndarray:
    """An agent 0.55 m in front of the camera, facing it, its gaze controller aimed at ``gaze``."""
    w, h = 120, 90
    snap, _ = posed([[0.55, 0.0]], [math.pi], seconds=1.5, gaze={0: gaze}, reference=True)
    cam = EyeView.from_pose(
        rotation=first_person_rotation(0.0),
        position=np.array([0.0, EYE_H, 0.0]),
        projection=first_person_eye(
            pos=np.zeros(2), heading=0.0, fovy=math.radians(30), aspect=w / h
        ).projection,
    )
    return render(renderer, snap, [cam], size=(w, h))


def _pupil_offset(img: np.ndarray) -> tuple[float, int]:
    """Horizontal offset (px) of the dark pupil pixels from the centre of the eye whites."""
    white = (img.min(axis=2) > 170) & (np.ptp(img, axis=2) < 30)
    rows, cols = np.nonzero(white)
    assert rows.size > 4, "no eye whites visible"
    r0, r1, c0, c1 = rows.min() - 2, rows.max() + 3, cols.min() - 2, cols.max() + 3
    region = img[r0:r1, c0:c1]
    dark = region.max(axis=2) < 40
    pr, pc = np.nonzero(dark)
    # Against the middle of the whites' extent (their mean leans toward the lit side).
    return float(pc.mean() + c0 - (cols.min() + cols.max()) / 2) if pc.size else float("nan"), int(pc.size)


def test_an_agent_gazing_at_the_camera_shows_its_pupils_centred_toward_it(renderer: Renderer) -> None:
    off, n = _pupil_offset(_face(renderer, (0.0, EYE_H, 0.0)))  # the body's gaze_at the camera
    assert n >= 8 and abs(off) < 2.0  # pupils in the middle of the whites: looking at us
    # The agent at 2D (0.55, 0) faces 2D -x; its right is heading + 90° = 2D -y, its left 2D +y (math3d's
    # chirality note). The camera faces 2D +x, so its right is 2D +y: the agent's left looks camera-right.
    off_left, n_left = _pupil_offset(_face(renderer, (-0.45, EYE_H, 0.6)))
    off_right, n_right = _pupil_offset(_face(renderer, (-0.45, EYE_H, -0.6)))
    assert n_left >= 2 and n_right >= 2
    assert off_left > off + 1.5 and off_right < off - 1.5


def test_the_red_target_sphere_is_red_and_in_front(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.4, aspect=W / H)
    snap = Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0), sphere=np.array([3.0, 0.0]))
    img = render(renderer, snap, [eye])
    c = img[H // 2, W // 2]
    assert c[0] > 150 and c[1] < 60 and c[2] < 60


def test_draw_calls_do_not_grow_with_the_crowd(renderer: Renderer) -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, aspect=W / H)
    counts = []
    for n in (1, 40, 300):
        pos = np.stack([3 + np.arange(n) % 20, np.arange(n) // 20 - 7.0], axis=1).astype(float)
        render(renderer, Snapshot.of_agents(pos=pos, heading=np.zeros(n)), [eye])
        counts.append(renderer.stats.draw_calls)
    assert counts[0] == counts[1] == counts[2] == 4


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
