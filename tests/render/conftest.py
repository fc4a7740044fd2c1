"""Shared GL fixtures: one EGL context (Mesa llvmpipe on CI) and small offscreen targets."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import pytest

from pedvr.render.renderer import Renderer, create_offscreen_context
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
