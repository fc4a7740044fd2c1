"""Carried things drawn (issue 14, Huang & Terzopoulos §4.6): a cardboard box between a carrier's
hands and a perambulator ahead of its pusher, in the first-person and the overhead view."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pedvr.body import FullBody, carry
from pedvr.body import skeleton as sk
from pedvr.crowd.state import CrowdState
from pedvr.render.carried import carried_vertices, frames, outline_segments
from pedvr.render.math3d import first_person_eye, overhead_transform, project
from pedvr.render.renderer import OffscreenTarget, Renderer
from pedvr.render.snapshot import Snapshot

W, H = 160, 120


def _walking(pos: np.ndarray, heading: np.ndarray, kinds: tuple[str, ...], *,
             speed: float = 1.0, seconds: float = 1.0) -> tuple[Snapshot, FullBody]:
    """Bodies walking along their headings for ``seconds``, each carrying ``kinds[i]``."""
    n = pos.shape[0]
    ids = np.arange(n, dtype=np.int64)
    body = FullBody(rng=np.random.default_rng(3))
    for i, k in enumerate(kinds):
        body.append(1, ids=ids[i:i + 1], pos=pos[i:i + 1], heading=heading[i:i + 1], is_user=False,
                    dims=sk.user_dims(1), carrying=k)
    v = speed * np.stack([np.cos(heading), np.sin(heading)], axis=1)
    crowd = CrowdState(
        ids=ids, pos=pos.copy(), vel=np.zeros((n, 2)), pref_vel=np.zeros((n, 2)), heading=heading.copy(),
        pref_heading=heading.copy(), radius=np.full(n, 0.3), pref_speed=np.full(n, 1.3),
        max_speed=np.full(n, 1.6), responsibility=np.full(n, 0.5), is_user=np.zeros(n, np.bool_),
        limits=np.zeros((n, 6)),
    )
    dt, t = 1.0 / 90.0, 0.0
    for _ in range(round(seconds / dt)):
        root = crowd.pos + v * dt
        t += dt
        body.compose(crowd, root, heading, dt=dt, t=t, coupled=True)
        crowd.pos, crowd.vel = root, v
    snap = Snapshot.of_agents(pos=crowd.pos, heading=heading, vel=v, ids=ids, bones=body.joint_matrices(),
                              dims=body.state.dims.copy(), t=t)
    return dataclasses.replace(snap, carrying=body.state.carrying.copy(),
                               carry_frame=body.state.carry_frame.copy()), body


def _draw(renderer: Renderer, snap: Snapshot, eye: object) -> np.ndarray:
    t = OffscreenTarget(renderer.ctx, (W, H))
    renderer.begin_frame()
    renderer.update(snap)
    renderer.draw_scene([eye], framebuffer=t.fbo)  # type: ignore[list-item]
    img = t.read().astype(np.int32)
    t.release()
    return img


def test_the_box_is_drawn_between_the_carriers_hands(renderer: Renderer) -> None:
    # A carrier 3 m ahead walking toward the eye: the box is in front of its chest.
    snap, body = _walking(np.array([[3.6, 0.0]]), np.array([math.pi]), ("box",))
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.5, aspect=W / H)
    with_box = _draw(renderer, snap, eye)
    without = _draw(renderer, dataclasses.replace(snap, carrying=None), eye)
    hands = body.state.world_pos[0, [sk.L_HAND, sk.R_HAND]]
    px = project(eye.view_projection, hands, width=W, height=H)
    mid = project(eye.view_projection, hands.mean(axis=0), width=W, height=H)
    # The hands are on the box's sides (both arms reached the carry points).
    tg = carry.hand_targets(body.state.carrying, body.state.root, body.state.heading,
                            body.state.dims[:, sk.DIM_SCALE])[0]
    assert np.abs(hands - tg).max() < 0.02
    assert abs(px[0, 0] - px[1, 0]) > 4  # the hands are well apart on screen
    r, c = int(mid[1]), int(mid[0])
    patch = with_box[r - 1:r + 2, c - 1:c + 2].reshape(-1, 3)
    # Cardboard between the hands (a warm brown: red over green over blue), where there was none.
    assert np.all(patch[:, 0] > patch[:, 1]) and np.all(patch[:, 1] > patch[:, 2])
    assert np.all(patch[:, 0] - patch[:, 2] > 40)
    assert np.abs(patch - without[r - 1:r + 2, c - 1:c + 2].reshape(-1, 3)).max() > 20
    # Only around the carrier does the image change.
    changed = np.abs(with_box - without).max(axis=2) > 8
    cols = np.flatnonzero(changed.any(axis=0))
    assert cols.size and cols.min() >= min(px[:, 0]) - 6 and cols.max() <= max(px[:, 0]) + 6


def test_the_pram_is_drawn_ahead_of_its_pusher_first_person_and_overhead(renderer: Renderer) -> None:
    # A pusher crossing the view 4 m ahead, side on: the pram is on one side of it on screen.
    snap, body = _walking(np.array([[4.0, 1.0]]), np.array([-math.pi / 2]), ("perambulator",))
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.5, aspect=W / H)
    img = _draw(renderer, snap, eye)
    without = _draw(renderer, dataclasses.replace(snap, carrying=None), eye)
    p, f = snap.pos[0], np.array([0.0, -1.0])
    a0, a1, y0, y1, _ = carry.PRAM_BASKET
    basket = project(eye.view_projection, np.array([p[0], (y0 + y1) / 2, p[1]]) + np.array(
        [f[0], 0.0, f[1]]) * (a0 + a1) / 2, width=W, height=H)
    r, c = int(basket[1]), int(basket[0])
    patch = img[r - 1:r + 2, c - 1:c + 2].reshape(-1, 3)
    assert np.all(patch[:, 2] > patch[:, 0] + 15)  # the navy basket
    assert np.abs(patch - without[r - 1:r + 2, c - 1:c + 2].reshape(-1, 3)).max() > 20
    # Every changed pixel is on the pram's side of the pusher (ahead of it), none behind.
    root_px = project(eye.view_projection, np.array([p[0], 1.0, p[1]]), width=W, height=H)
    changed = np.abs(img - without).max(axis=2) > 8
    cols = np.flatnonzero(changed.any(axis=0))
    side = np.sign(basket[0] - root_px[0])
    assert abs(basket[0] - root_px[0]) > 8
    assert cols.size > 10 and np.all((cols - root_px[0]) * side >= -3)
    # Wheels on the floor: dark pixels at the front wheels' hubs.
    hub = project(eye.view_projection, np.array([p[0] + 0.25, carry.PRAM_WHEEL_RADIUS,
                                                 p[1] - carry.PRAM_AXLES[1]]), width=W, height=H)
    assert img[int(hub[1]), int(hub[0])].max() < 90

    # Overhead: the outline lies ahead of the pusher, and its pixels are drawn there.
    ends, kinds = outline_segments(snap.carrying, snap.carry_frame, np.ones(1))
    along = (ends - p) @ f
    assert np.all(kinds == carry.PERAMBULATOR) and along.min() > 0.3 and along.max() < 1.3
    t = OffscreenTarget(renderer.ctx, (W, H))
    centre, extent = (4.0, 0.5), 3.0
    renderer.draw_overhead(framebuffer=t.fbo, center=centre, extent=extent, snap=snap)
    top = t.read().astype(np.int32)
    renderer.draw_overhead(framebuffer=t.fbo, center=centre, extent=extent,
                           snap=dataclasses.replace(snap, carrying=None))
    plain = t.read().astype(np.int32)
    t.release()
    diff = np.argwhere(np.abs(top - plain).max(axis=2) > 20)
    assert diff.shape[0] > 20
    m = overhead_transform(center=centre, extent=extent, aspect=W / H)
    ndc = np.stack([(diff[:, 1] + 0.5) / W * 2 - 1, 1 - (diff[:, 0] + 0.5) / H * 2, np.ones(len(diff))], 1)
    ground = ndc @ np.linalg.inv(m).T
    ahead = (ground[:, :2] - p) @ f
    assert ahead.min() > 0.2 and ahead.max() < 1.4


def test_carried_vertices_follow_the_body_frame() -> None:
    """One box and one pram: the box's vertices lie in the box, the pram's ahead of its root."""
    pos = np.array([[1.0, 2.0], [-3.0, 0.5]])
    heading = np.array([0.3, 2.0])
    kind = np.array([carry.BOX, carry.PERAMBULATOR], np.int8)
    v = carried_vertices(kind, frames(kind, None, pos, heading, np.ones(2)), np.ones(2))
    f = np.stack([np.cos(heading), np.sin(heading)], 1)
    nb = len(carried_vertices(kind[:1], frames(kind[:1], None, pos[:1], heading[:1], np.ones(1)), np.ones(1)))
    box, pram = v["pos"][:nb], v["pos"][nb:]
    ahead = (box[:, [0, 2]] - pos[0]) @ f[0]
    assert np.allclose([ahead.min(), ahead.max()], [carry.BOX_AHEAD - 0.15, carry.BOX_AHEAD + 0.15], atol=1e-5)
    assert box[:, 1].min() > 0.9 and box[:, 1].max() < 1.25
    ahead = (pram[:, [0, 2]] - pos[1]) @ f[1]
    assert ahead.min() > 0.3 and ahead.max() <= carry.PRAM_FRONT + 1e-5
    assert pram[:, 1].min() > -1e-6  # wheels on the floor, not through it
    assert np.allclose(np.linalg.norm(v["normal"], axis=1), 1.0, atol=1e-5)


def test_a_box_tilted_in_the_hands_is_drawn_tilted() -> None:
    """A box held with the left hand 2 cm above the right (a chest turned while walking) is drawn
    with its left side up by the same, not level between them."""
    kind = np.array([carry.BOX], np.int8)
    d, h, w = carry.BOX_SIZE
    # facing +x (yaw 0): the left side is (sin 0, 0, -cos 0) = -z
    hands = np.array([[[0.3, 1.01, -w / 2], [0.3, 0.99, w / 2]]])
    fr = carry.object_frame(kind, np.zeros((1, 2)), np.zeros(1), np.ones(1), hands, np.zeros((1, 2), np.bool_))
    assert math.isclose(fr[0, 4], math.asin(0.02 / math.hypot(0.02, w)), rel_tol=1e-9)
    v = carried_vertices(kind, fr, np.ones(1))["pos"]
    left, right = v[v[:, 2] < 0.0], v[v[:, 2] > 0.0]  # the box is centred between the hands (z 0)
    assert math.isclose(left[:, 1].mean() - right[:, 1].mean(), 0.02, abs_tol=1e-3)  # the left side higher
    level = fr.copy()
    level[0, 4] = 0.0
    flat = carried_vertices(kind, level, np.ones(1))["pos"]
    assert abs(flat[flat[:, 2] < 0.0][:, 1].mean() - flat[flat[:, 2] > 0.0][:, 1].mean()) < 1e-6
