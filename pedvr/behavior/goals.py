"""Goal selectors for BFSM states (PedVR §4.3, after Menge's goal selectors).

A selector turns a state's parameters and the agent's situation into a goal
point, or ``None`` (stand still). Scenes name selectors by their registered
name; their parameters are validated at scene load through ``PARAMS``.

Registered selectors:

``point``     ``at = [x, y]``: a fixed point.
``set``       ``set = "name"``: weighted random from a named goal set; with
              ``avoid_current = true`` (default) the point the agent is at is
              not drawn again while there is another.
``circle``    ``center, radius, spread``: a point on a circle. The angle is the
              antipode of the agent's own angle plus Gaussian noise of
              standard deviation ``spread`` (rad). This is our reading of the
              Antipodal Circle scene (PedVR §5, §6.2.2): goals biased toward
              the far side so paths, and density, peak at the centre;
              ``spread = 3.14`` or more gives nearly uniform goals.
``region``    ``box = [xmin, ymin, xmax, ymax]``: a uniformly random walkable point.
``sequence``  the spawn's per-agent goal sequence (SteerSuite ``goalSequence``).
``stay``      no goal: the agent stands where it is.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from pedvr.registry import Registry
from pedvr.scene.config import GoalSet, SequenceGoal, Vec2


class Walkable(Protocol):
    """What selectors need of the world (a :class:`pedvr.world.NavMesh`)."""

    def random_point(self, rng: np.random.Generator, region: Any = None) -> Vec2: ...

    def nearest_walkable(self, p: Vec2) -> Vec2: ...


@dataclass
class GoalContext:
    """The agent's situation when a selector runs."""

    rng: np.random.Generator
    pos: Vec2
    walkable: Walkable
    goal_sets: dict[str, GoalSet]
    current_goal: Vec2 | None = None
    sequence: tuple[SequenceGoal, ...] = ()
    sequence_index: int = 0


# Parameter checks: each returns an expectation string when the value is bad.
Check = Callable[[object], str | None]


def _num(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(float(v))


def vec2(v: object) -> str | None:
    ok = isinstance(v, list | tuple) and len(v) == 2 and all(_num(x) for x in v)
    return None if ok else "expected [x, y] in metres"


def positive(v: object) -> str | None:
    return None if _num(v) and float(v) > 0 else "must be a number > 0"  # type: ignore[arg-type]


def non_negative(v: object) -> str | None:
    return None if _num(v) and float(v) >= 0 else "must be a number >= 0"  # type: ignore[arg-type]


def name(v: object) -> str | None:
    return None if isinstance(v, str) and v else "expected a non-empty string"


def boolean(v: object) -> str | None:
    return None if isinstance(v, bool) else "expected true or false"


def box(v: object) -> str | None:
    if not (isinstance(v, list | tuple) and len(v) == 4 and all(_num(x) for x in v)):
        return "expected [xmin, ymin, xmax, ymax]"
    x0, y0, x1, y1 = (float(x) for x in v)
    return None if x0 < x1 and y0 < y1 else "expected xmin < xmax and ymin < ymax"


@dataclass(frozen=True)
class Param:
    check: Check
    required: bool = True


class Selector(Protocol):
    PARAMS: dict[str, Param]

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None: ...


selectors: Registry[Selector] = Registry("goal selector")


class _Point:
    PARAMS = {"at": Param(vec2)}

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        x, y = params["at"]
        return (float(x), float(y))


class _Set:
    PARAMS = {"set": Param(name), "avoid_current": Param(boolean, required=False)}

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        gs = ctx.goal_sets[params["set"]]
        w = np.asarray(gs.weights, dtype=np.float64)
        pts = np.asarray(gs.points, dtype=np.float64)
        if params.get("avoid_current", True) and len(gs.points) > 1:
            here = np.asarray(ctx.current_goal if ctx.current_goal is not None else ctx.pos)
            w = np.where(np.linalg.norm(pts - here, axis=1) < 0.5, 0.0, w)
            if w.sum() <= 0:
                w = np.asarray(gs.weights, dtype=np.float64)
        k = int(ctx.rng.choice(len(w), p=w / w.sum()))
        return (float(pts[k, 0]), float(pts[k, 1]))


class _Circle:
    PARAMS = {"center": Param(vec2), "radius": Param(positive), "spread": Param(non_negative)}

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        cx, cy = (float(c) for c in params["center"])
        own = math.atan2(ctx.pos[1] - cy, ctx.pos[0] - cx)
        angle = own + math.pi + float(params["spread"]) * float(ctx.rng.standard_normal())
        r = float(params["radius"])
        return ctx.walkable.nearest_walkable((cx + r * math.cos(angle), cy + r * math.sin(angle)))


class _Region:
    PARAMS = {"box": Param(box)}

    def __init__(self) -> None:
        self._boxes: dict[tuple[float, ...], Any] = {}  # box -> its shapely polygon, made once

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        key = tuple(float(v) for v in params["box"])
        region = self._boxes.get(key)
        if region is None:
            from shapely.geometry import box as shapely_box

            region = self._boxes[key] = shapely_box(*key)
        return ctx.walkable.random_point(ctx.rng, region)


class _Sequence:
    """Walks the spawn's goal sequence; the BFSM advances ``sequence_index``."""

    PARAMS: dict[str, Param] = {}

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        if ctx.sequence_index >= len(ctx.sequence):
            return None
        g = ctx.sequence[ctx.sequence_index]
        if g.kind == "seek":
            return g.target
        if g.kind == "flee":
            d = np.subtract(ctx.pos, g.target)
            n = float(np.linalg.norm(d)) or 1.0
            far = np.add(ctx.pos, d / n * 1000.0)
            return ctx.walkable.nearest_walkable((float(far[0]), float(far[1])))
        if g.kind == "flow":
            d = np.asarray(g.target, dtype=np.float64)
            n = float(np.linalg.norm(d)) or 1.0
            far = np.add(ctx.pos, d / n * 1000.0)
            return ctx.walkable.nearest_walkable((float(far[0]), float(far[1])))
        return None  # idle


class _Stay:
    PARAMS: dict[str, Param] = {}

    def __call__(self, params: dict[str, Any], ctx: GoalContext) -> Vec2 | None:
        return None


for _name, _cls in (("point", _Point), ("set", _Set), ("circle", _Circle), ("region", _Region),
                    ("sequence", _Sequence), ("stay", _Stay)):
    selectors.register(_name)(_cls())


def validate_params(kind: str, params: dict[str, Any]) -> list[tuple[str, object, str]]:
    """Problems with a selector's parameters as ``(key, value, expectation)``."""
    spec = selectors[kind].PARAMS
    out: list[tuple[str, object, str]] = []
    for key, p in spec.items():
        if key not in params:
            if p.required:
                out.append((key, "<missing>", "required"))
            continue
        why = p.check(params[key])
        if why:
            out.append((key, params[key], why))
    for key in params:
        if key not in spec:
            known = ", ".join(sorted(spec)) or "none"
            out.append((key, params[key], f"unknown parameter of selector {kind!r}; known: {known}"))
    return out
