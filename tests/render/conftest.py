"""Shared GL fixtures: one EGL context (Mesa llvmpipe on CI) and small offscreen targets."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

from pedvr.body import FullBody
from pedvr.body import skeleton as sk
from pedvr.crowd.state import CrowdState
from pedvr.render.renderer import Renderer, create_offscreen_context
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import Obstacle, WorldConfig

WORLD = WorldConfig(
    bounds=((-10.0, -10.0), (10.0, 10.0)),
    obstacles=(Obstacle(vertices=((6.0, 3.0), (7.0, 3.0), (7.0, 4.0), (6.0, 4.0)), kind="box", height=1.0),),
)
EMPTY = WorldConfig(bounds=((-30.0, -30.0), (30.0, 30.0)))


@pytest.fixture(scope="session")
def ctx() -> Iterator[moderngl.Context]:
    c = create_offscreen_context()
    yield c
    c.release()


@pytest.fixture(scope="session")
def renderer(ctx: moderngl.Context) -> Iterator[Renderer]:
    r = Renderer(ctx, world=EMPTY)
    yield r
    r.release()


def posed(
    pos: object,
    heading: object,
    *,
    vel: object | None = None,
    seconds: float = 1.0,
    gaze: dict[int, object] | None = None,
    reference: bool = False,
    is_user: np.ndarray | None = None,
    sphere: np.ndarray | None = None,
) -> tuple[Snapshot, FullBody]:
    """A snapshot drawn from a real :class:`FullBody`: agents at ``pos`` walking at ``vel`` for ``seconds``.

    ``gaze`` maps an agent id to a ``gaze_at`` target; ``reference`` gives everyone the 1.75 m
    reference body (eyes at 1.64 m) instead of drawn dimensions.
    """
    p = np.asarray(pos, np.float64).reshape(-1, 2)
    n = p.shape[0]
    h = np.asarray(heading, np.float64).reshape(n)
    v = np.zeros((n, 2)) if vel is None else np.asarray(vel, np.float64).reshape(n, 2)
    user = np.zeros(n, np.bool_) if is_user is None else np.asarray(is_user, np.bool_)
    ids = np.arange(n, dtype=np.int64)
    body = FullBody(rng=np.random.default_rng(0))
    body.append(n, ids=ids, pos=p, heading=h, is_user=False, dims=sk.user_dims(n) if reference else None)
    for agent, target in (gaze or {}).items():
        body.gaze_at(agent, target)
    crowd = CrowdState(
        ids=ids, pos=p.copy(), vel=np.zeros((n, 2)), pref_vel=np.zeros((n, 2)), heading=h.copy(),
        pref_heading=h.copy(), radius=np.full(n, 0.25), pref_speed=np.full(n, 1.3), max_speed=np.full(n, 1.6),
        responsibility=np.full(n, 0.5), is_user=user, limits=np.zeros((n, 6)),
    )
    dt, t = 1.0 / 90.0, 0.0
    for _ in range(max(1, round(seconds / dt))):
        root = crowd.pos + v * dt
        t += dt
        body.compose(crowd, root, h, dt=dt, t=t, coupled=True)
        crowd.pos, crowd.vel = root, v
    snap = Snapshot.of_agents(
        pos=crowd.pos, heading=h, vel=v, ids=ids, is_user=user, bones=body.joint_matrices(),
        dims=body.state.dims.copy(), sphere=sphere, t=t,
    )
    return snap, body
