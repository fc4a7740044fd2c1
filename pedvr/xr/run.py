"""``pedvr run`` with a view: build the backend, prepare, run the frame loop, save the run.

One entry point for the three presenters (openxr, desktop, headless with
files). The backend is built before the simulation, so a backend that cannot
start costs nothing and fails with one line. Before the first frame the run is
prepared (:mod:`pedvr.prepare`): the first step of a simulation of the same
scene compiles numba's kernels and one frame of it is drawn with the
backend's own programs, saying what is happening; in the headset this happens
before the first ``xrWaitFrame`` (issue 23 item 2). The trajectory and metrics
are written by :mod:`pedvr.outputs`, with the frame loop's telemetry under
``frames`` (kept on Ctrl-C, SIGTERM and SIGHUP too), what preparing took
under ``prepare``, and the OpenGL renderer's name under ``renderer`` (in the
headset too: llvmpipe there is a software renderer as anywhere else).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pedvr import warmup
from pedvr.errors import BackendUnavailableError
from pedvr.outputs import interrupted_by, signals_interrupt, write_outputs
from pedvr.prepare import CompileLog, Prepared, prepare, set_up, stderr_say
from pedvr.render.math3d import EyeView, first_person_eye
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import SceneConfig
from pedvr.signals import calls_restart
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


@dataclass
class Built:
    """A backend ready to run: the simulation, its presenter, the renderer's name, and how to
    prepare (``make_sim``: a fresh simulation of the same run; ``draw``: one frame of one)."""

    sim: Simulation
    presenter: Presenter
    renderer: str
    make_sim: Callable[[], Simulation]
    draw: Callable[[Simulation], object]


def _xr_presenter(scene: SceneConfig) -> tuple[XrPresenter, HeadsetUser, Callable[[Simulation], None]]:
    from pedvr.render.renderer import Renderer
    from pedvr.xr.locomotion import HeadsetUser, WalkableArea
    from pedvr.xr.openxr import OpenXRPort
    from pedvr.xr.session import XrPresenter

    port = OpenXRPort.open()
    try:
        user = HeadsetUser(
            start=scene.user.start,
            heading=scene.user.heading,
            walkable=WalkableArea(scene.world, radius=scene.user.radius),
        )
        renderer = Renderer.for_scene(port.ctx, scene)
    except BaseException:
        port.close()
        raise

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

    def draw_once(sim: Simulation) -> None:
        """One eye of ``sim`` into targets like the swapchains' (same format, size and depth), so
        the driver has compiled every program variant before the first xrWaitFrame."""
        snap = Snapshot.from_sim(sim)
        renderer.begin_frame()
        renderer.update(snap)
        u = snap.user_row if snap.user_row is not None else 0
        w, h = port.sizes[0]
        eye = first_person_eye(pos=snap.pos[u], heading=float(snap.heading[u]), aspect=w / h)
        with port.offscreen_target() as fbo:
            draw_eye(eye, fbo, (0, 0, w, h))
            port.ctx.finish()

    return XrPresenter(port, user=user, draw_eye=draw_eye, update=update), user, draw_once


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
) -> Built:
    """The simulation, its presenter, the renderer's name and how to prepare them; raises
    BackendUnavailableError.

    ``user_walk`` applies to the headless backend's scripted user only; a real user
    walks as they like."""
    crowd_opts: dict[str, Any] = {"seed": seed, "condition": condition, "responsibility": responsibility,
                                  "personal_space": personal_space, "record": True}
    if backend == "xr":
        from pedvr.xr.locomotion import HeadsetUser

        presenter, user, draw = _xr_presenter(scene)
        sim = Simulation(scene, user_input=user, **crowd_opts)
        return Built(
            sim, presenter, presenter.port.renderer_name,  # type: ignore[attr-defined]
            lambda: Simulation(scene, user_input=HeadsetUser(start=scene.user.start,
                                                             heading=scene.user.heading), **crowd_opts),
            draw,
        )
    if backend == "desktop":
        from pedvr.xr.desktop import DesktopPresenter
        from pedvr.xr.locomotion import KeyboardMouseUser, WalkableArea

        def keyboard() -> KeyboardMouseUser:
            return KeyboardMouseUser(
                start=scene.user.start,
                heading=scene.user.heading,
                walkable=WalkableArea(scene.world, radius=scene.user.radius),
            )

        kb = keyboard()
        desk = DesktopPresenter(
            scene,
            user=kb,
            width=opts.width,
            height=opts.height,
            view=opts.view,
            hud_label=opts.label,
            vsync=opts.vsync,
        )
        sim = Simulation(scene, user_input=kb, **crowd_opts)

        def draw_desktop(s: Simulation) -> None:
            desk.render(s)  # into the back buffer, never swapped: the first real frame clears it
            desk.ctx.finish()

        return Built(sim, desk, str(desk.ctx.info.get("GL_RENDERER", "unknown")),
                     lambda: Simulation(scene, user_input=keyboard(), **crowd_opts), draw_desktop)
    if backend == "headless":
        from pedvr.xr.offscreen import OffscreenPresenter

        sim = Simulation(scene, user_walk=user_walk, **crowd_opts)
        head = OffscreenPresenter(
            sim,
            frames_dir=opts.frames,
            video=opts.video,
            view=opts.view,
            width=opts.width,
            height=opts.height,
            fps=opts.fps,
            hud_label=opts.label,
        )
        return Built(sim, head, head.renderer_name,
                     lambda: Simulation(scene, user_walk=user_walk, **crowd_opts), head.draw)
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
    progress: bool = True,
) -> dict[str, object]:
    """Prepare, run the frame loop on ``backend`` and save the run (see
    :func:`pedvr.outputs.write_outputs`). Ctrl-C, SIGTERM and SIGHUP end the loop early and keep
    the outputs and the telemetry so far (``interrupted`` names the signal)."""
    duration = scene.duration if duration is None else duration
    t0 = time.perf_counter()
    say = stderr_say if progress else None
    # building the run's simulation compiles the world's kernels and the pose graph on a cold cache
    # (pedvr.warmup: the step's compile meanwhile in a second process): said as it happens
    built, compiled = set_up(lambda: build(
        scene, backend=backend, opts=opts, seed=seed, condition=condition, responsibility=responsibility,
        personal_space=personal_space, user_walk=user_walk,
    ), say=say)
    sim, presenter = built.sim, built.presenter
    interrupted: bool | str = False
    tel = Telemetry(backend=presenter.name)
    prepared: Prepared | None = None
    # XR: a signal never fails a runtime call in progress (pedvr.signals.calls_restart), so a
    # Ctrl-C or a kill still ends the session politely
    restart = calls_restart if backend == "xr" else nullcontext
    try:
        with signals_interrupt(), restart():
            prepared = prepare(built.make_sim, what=f"{scene.name} ({backend})", draw=built.draw, say=say,
                               warmer=warmup.take())
            prepared.kernels_compiled += compiled  # building the run's own simulation compiled these
            with CompileLog() as later:
                try:
                    run_frames(sim, presenter, duration=duration, telemetry=tel,
                               offline=backend == "headless")
                finally:
                    prepared.compiled_during_run = later.names
    except KeyboardInterrupt as exc:
        interrupted = interrupted_by(exc)
    finally:
        with signals_interrupt(), restart():  # a second signal must not cut the session's end short
            _finish(presenter)
            presenter.close()
    wall = time.perf_counter() - t0
    from pedvr.xr.session import XrPresenter

    lost = presenter.lost if isinstance(presenter, XrPresenter) else None
    extra: dict[str, object] = {
        "frames": tel.summary(),
        "renderer": built.renderer,
        "backend": backend,
        "interrupted": interrupted,
        "wall_s": round(wall, 3),
        "realtime_factor": round(sim.t / wall, 2) if wall > 0 else None,
        "prepare": prepared.summary() if prepared is not None else None,
    }
    if isinstance(presenter, XrPresenter):
        extra["xr"] = {
            "session_states": [st.name for st in presenter.logic.history],
            "eyes_rendered": list(presenter.eyes_rendered),
            "runtime": presenter.facts,
        }
    if lost:
        extra["backend_lost"] = lost
    summary = write_outputs(
        sim, scene, condition=condition, record=record, metrics_json=metrics_json, out=out, extra=extra
    )
    f = tel.summary()
    print(
        f"  frames {f['frames']} ({backend}, {built.renderer}), render p50 {f['render_ms_p50']} ms, "
        f"sim p50 {f['sim_ms_p50']} ms, {missed_line(f, built.renderer)}"
    )
    if opts.frames is not None:
        print(f"  frames:     {opts.frames}/first_person, {opts.frames}/overhead")
    if opts.video is not None:
        print(f"  video:      {opts.video}")
    if lost_first(interrupted, lost):
        from pedvr.xr.session import BackendLostError

        raise BackendLostError(f"the OpenXR session ended early: {lost}")
    return summary


def lost_first(interrupted: bool | str, lost: str | None) -> bool:
    """Whether the runtime going away ended the run (exit 3), rather than a signal. A Ctrl-C that
    lands while the runtime's client library waits in a call (Monado's ``recvmsg``) interrupts
    that call, which then reports the session lost; the signal came first, so the run ends as
    interrupted (130 for Ctrl-C) with ``backend_lost`` in its metrics."""
    return lost is not None and not interrupted


def _finish(presenter: Presenter) -> None:
    """After the run, end an OpenXR session politely (:meth:`XrPresenter.finish`)."""
    from pedvr.xr.session import XrPresenter

    if isinstance(presenter, XrPresenter):
        presenter.finish()
