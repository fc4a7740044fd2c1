"""``pedvr run`` with a view: build the backend, run the frame loop, save the run.

One entry point for the three presenters (openxr, desktop, headless with
files). The backend is built before the simulation, so a backend that cannot
start costs nothing and fails with one line. The trajectory and metrics are
written as by the plain headless run, with the frame loop's telemetry under
``frames`` and the OpenGL renderer's name under ``renderer``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pedvr.errors import BackendUnavailableError
from pedvr.render.math3d import EyeView
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import SceneConfig
from pedvr.sim import Simulation
from pedvr.xr.loop import Presenter, Telemetry, missed_line, run_frames

if TYPE_CHECKING:
    from pedvr.xr.locomotion import HeadsetUser
    from pedvr.xr.session import XrPresenter


@dataclass(frozen=True)
class ViewOptions:
    """What to show and where: ``frames``/``video`` (headless), ``view`` mode, size, rate, HUD label."""

    frames: Path | None = None
    video: Path | None = None
    view: str = "mono"
    width: int = 640
    height: int = 360
    fps: float = 30.0
    label: str | None = None
    vsync: bool = True


def _xr_presenter(scene: SceneConfig, opts: ViewOptions) -> tuple[XrPresenter, HeadsetUser]:
    from pedvr.render.renderer import Renderer
    from pedvr.xr.locomotion import HeadsetUser, WalkableArea
    from pedvr.xr.openxr import OpenXRPort
    from pedvr.xr.session import XrPresenter

    port = OpenXRPort.open()
    user = HeadsetUser(
        start=scene.user.start,
        heading=scene.user.heading,
        walkable=WalkableArea(scene.world, radius=scene.user.radius),
    )
    renderer = Renderer.for_scene(port.ctx, scene)

    def update(sim: Simulation) -> None:
        renderer.begin_frame()
        renderer.update(Snapshot.from_sim(sim))

    def draw_eye(eye: EyeView, fbo: object, viewport: tuple[int, int, int, int]) -> None:
        renderer.draw_scene([eye], framebuffer=fbo, viewport=viewport, srgb_encode=not port.srgb)  # type: ignore[arg-type]
        renderer.draw_vignette(
            min(1.0, user.moving_speed / 1.3) * 0.6,
            framebuffer=fbo,  # type: ignore[arg-type]
            viewport=viewport,
        )

    return XrPresenter(port, user=user, draw_eye=draw_eye, update=update), user


def build(
    scene: SceneConfig,
    *,
    backend: str,
    opts: ViewOptions,
    seed: int | None,
    condition: str,
    responsibility: float | None,
    personal_space: float | None = None,
    user_walk: str | None = None,
) -> tuple[Simulation, Presenter, str]:
    """The simulation, its presenter, and the renderer's name; raises BackendUnavailableError.

    ``user_walk`` applies to the headless backend's scripted user only; a real user
    walks as they like."""
    crowd_opts = {"seed": seed, "condition": condition, "responsibility": responsibility,
                  "personal_space": personal_space, "record": True}
    if backend == "xr":
        presenter, user = _xr_presenter(scene, opts)
        sim = Simulation(scene, user_input=user, **crowd_opts)  # type: ignore[arg-type]
        return sim, presenter, "openxr"
    if backend == "desktop":
        from pedvr.xr.desktop import DesktopPresenter
        from pedvr.xr.locomotion import KeyboardMouseUser, WalkableArea

        kb = KeyboardMouseUser(
            start=scene.user.start,
            heading=scene.user.heading,
            walkable=WalkableArea(scene.world, radius=scene.user.radius),
        )
        desk = DesktopPresenter(
            scene,
            user=kb,
            width=opts.width,
            height=opts.height,
            view=opts.view,
            hud_label=opts.label,
            vsync=opts.vsync,
        )
        sim = Simulation(scene, user_input=kb, **crowd_opts)  # type: ignore[arg-type]
        return sim, desk, str(desk.ctx.info.get("GL_RENDERER", "unknown"))
    if backend == "headless":
        from pedvr.xr.headless import HeadlessPresenter

        sim = Simulation(scene, user_walk=user_walk, **crowd_opts)  # type: ignore[arg-type]
        head = HeadlessPresenter(
            sim,
            frames_dir=opts.frames,
            video=opts.video,
            view=opts.view,
            width=opts.width,
            height=opts.height,
            fps=opts.fps,
            hud_label=opts.label,
        )
        return sim, head, head.renderer_name
    raise BackendUnavailableError(f"backend {backend!r}: expected xr, desktop or headless")


def run_with_view(
    scene: SceneConfig,
    *,
    backend: str,
    opts: ViewOptions,
    duration: float | None,
    seed: int | None,
    condition: str,
    responsibility: float | None,
    record: Path | None,
    metrics_json: Path | None,
    out: Path,
    personal_space: float | None = None,
    user_walk: str | None = None,
) -> dict[str, object]:
    """Run the frame loop on ``backend`` and save the run (see :func:`pedvr.headless.write_outputs`)."""
    from pedvr.headless import write_outputs

    duration = scene.duration if duration is None else duration
    t0 = time.perf_counter()
    sim, presenter, renderer_name = build(
        scene, backend=backend, opts=opts, seed=seed, condition=condition, responsibility=responsibility,
        personal_space=personal_space, user_walk=user_walk,
    )
    interrupted = False
    tel = Telemetry(backend=presenter.name)
    try:
        tel = run_frames(sim, presenter, duration=duration)
        _finish_xr(presenter)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        presenter.close()
    wall = time.perf_counter() - t0
    from pedvr.xr.session import XrPresenter

    lost = presenter.lost if isinstance(presenter, XrPresenter) else None
    extra: dict[str, object] = {
        "frames": tel.summary(),
        "renderer": renderer_name,
        "backend": backend,
        "interrupted": interrupted,
        "wall_s": round(wall, 3),
        "realtime_factor": round(sim.t / wall, 2) if wall > 0 else None,
    }
    if lost:
        extra["backend_lost"] = lost
    summary = write_outputs(
        sim, scene, condition=condition, record=record, metrics_json=metrics_json, out=out, extra=extra
    )
    f = tel.summary()
    print(
        f"  frames {f['frames']} ({backend}, {renderer_name}), render p50 {f['render_ms_p50']} ms, "
        f"sim p50 {f['sim_ms_p50']} ms, {missed_line(f, renderer_name)}"
    )
    if opts.frames is not None:
        print(f"  frames:     {opts.frames}/first_person, {opts.frames}/overhead")
    if opts.video is not None:
        print(f"  video:      {opts.video}")
    if lost:
        from pedvr.xr.session import BackendLostError

        raise BackendLostError(f"the OpenXR session ended early: {lost}")
    return summary


def _finish_xr(presenter: Presenter, *, timeout: float = 5.0) -> None:
    """After the run, ask an OpenXR session to exit and keep submitting frames until it has."""
    from pedvr.xr.session import XrPresenter

    if not isinstance(presenter, XrPresenter) or presenter.closed:
        return
    presenter.request_exit()
    deadline = time.perf_counter() + timeout
    while not presenter.closed and time.perf_counter() < deadline:
        if presenter.wait_frame() is not None:
            presenter.end_frame()
