"""The frame loop: the simulation at its fixed ``dt``, decoupled from the display rate.

Each frame the presenter says when the frame will be seen (the predicted
display time in OpenXR, the wall clock after the last buffer swap on the
desktop, ``k / fps`` when rendering to files). The loop advances the
simulation to that time with :meth:`~pedvr.sim.Simulation.advance_to` (an
accumulator: zero, one or several fixed steps per frame), renders the
snapshot and records per-frame telemetry: simulation ms, render ms, frame
interval and missed frames (DESIGN.md "One step": rendering is not a phase).

When the simulation falls more than ``max_lag`` seconds behind the display
(a stall, a breakpoint), the clock skips ahead instead of running a burst of
steps (no spiral of death); skipped time is reported. An ``offline``
presenter (frames to files) has no wall clock to keep up with: every frame is
taken at its own simulated time and none after the run's duration.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from pedvr.sim import Simulation


@dataclass(frozen=True)
class FrameTiming:
    """When the next frame is displayed (s, presenter's clock), the display period, whether to draw."""

    display_time: float
    period: float
    should_render: bool = True


class Presenter(Protocol):
    """The frame-presenting half of a backend (the other half is its :class:`~pedvr.crowd.user.UserInput`)."""

    name: str

    @property
    def closed(self) -> bool:
        """True once the user or the runtime asked to stop."""
        ...

    def wait_frame(self) -> FrameTiming | None:
        """Block until the next frame may start; None when there is no frame to make now (session idle)."""
        ...

    def render(self, sim: Simulation) -> None:
        """Draw the simulation's current state for the frame ``wait_frame`` announced."""
        ...

    def end_frame(self) -> None:
        """Finish the frame (swap, submit layers, write files)."""
        ...

    def close(self) -> None: ...


@dataclass
class Telemetry:
    """Per-frame timings; :meth:`summary` goes into the run's metrics JSON under ``frames``."""

    sim_ms: list[float] = field(default_factory=list)
    render_ms: list[float] = field(default_factory=list)
    frame_ms: list[float] = field(default_factory=list)
    steps: list[int] = field(default_factory=list)
    missed_frames: int = 0
    refreshes: int = 0  # display refreshes between the first and the last frame
    period_s: float = 0.0  # the display's refresh period, s (the last one reported)
    skipped_sim_s: float = 0.0
    idle_polls: int = 0
    backend: str = ""

    def summary(self) -> dict[str, object]:
        """Counts and percentiles (``frame_ms_max``: the longest interval between two frames'
        display times, the worst stall a viewer saw)."""

        def pct(xs: list[float], q: float) -> float | None:
            return round(float(np.percentile(xs, q)), 3) if xs else None

        frames = len(self.render_ms)
        total_s = sum(self.frame_ms) / 1e3
        return {
            "backend": self.backend,
            "frames": frames,
            "fps": round(len(self.frame_ms) / total_s, 2) if total_s > 0 else None,
            "missed_frames": self.missed_frames,
            "display_refreshes": self.refreshes,
            "refresh_ms": round(self.period_s * 1e3, 3) if self.period_s > 0 else None,
            "skipped_sim_s": round(self.skipped_sim_s, 4),
            "sim_ms_p50": pct(self.sim_ms, 50),
            "sim_ms_p95": pct(self.sim_ms, 95),
            "render_ms_p50": pct(self.render_ms, 50),
            "render_ms_p95": pct(self.render_ms, 95),
            "render_ms_max": round(max(self.render_ms), 3) if self.render_ms else None,
            "frame_ms_p50": pct(self.frame_ms, 50),
            "frame_ms_p95": pct(self.frame_ms, 95),
            "frame_ms_max": round(max(self.frame_ms), 3) if self.frame_ms else None,
            "steps_per_frame_max": max(self.steps) if self.steps else 0,
        }


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "lavapipe", "software")


def missed_line(summary: dict[str, object], renderer: str) -> str:
    """One honest line on missed display refreshes: how many of how many, and why — the
    renderer or the simulation slower than a refresh, and whether the renderer is
    software (then the figure says nothing about a GPU headset's frame rate)."""
    missed = int(summary.get("missed_frames") or 0)  # type: ignore[call-overload]
    total = int(summary.get("display_refreshes") or 0)  # type: ignore[call-overload]
    refresh = summary.get("refresh_ms")
    if not total or refresh is None:
        return f"missed {missed} display refreshes"
    head = f"missed {missed} of {total} display refreshes ({100.0 * missed / total:.0f} %)"
    if missed == 0:
        return head
    why = []
    render = summary.get("render_ms_p50")
    sim = summary.get("sim_ms_p50")
    if isinstance(render, float) and render > float(refresh):  # type: ignore[arg-type]
        why.append(f"drawing a frame takes {render} ms at p50, longer than a {refresh} ms refresh")
    if isinstance(sim, float) and sim > float(refresh):  # type: ignore[arg-type]
        why.append(f"simulating a frame takes {sim} ms at p50")
    if any(k in renderer.lower() for k in SOFTWARE_RENDERERS):
        why.append(f"{renderer} is a software renderer: frame rates need a GPU")
    return head + (": " + "; ".join(why) if why else "")


def missed_between(interval: float, period: float) -> int:
    """Display refreshes missed between two frames ``interval`` s apart at ``period`` s per refresh."""
    if period <= 0 or interval <= 1.5 * period:
        return 0
    return int(round(interval / period)) - 1


def run_frames(
    sim: Simulation,
    presenter: Presenter,
    *,
    duration: float | None,
    max_lag: float = 0.25,
    clock: object = time.perf_counter,
    max_idle_polls: int | None = None,
    telemetry: Telemetry | None = None,
    offline: bool = False,
) -> Telemetry:
    """Run until ``duration`` simulated seconds or the presenter closes; return the telemetry.

    The first frame to be drawn (``should_render``) is shown at simulation time
    ``sim.t`` (after one step when the simulation has not stepped yet and the
    presenter is live: the first step poses the bodies); after that simulation
    time follows display time. Frames before it
    (an OpenXR session not yet visible) are ended without moving the simulation:
    nothing happens in the world before the participant can see it. ``clock`` (``() -> float`` seconds)
    times the work, injected for tests. ``max_idle_polls`` bounds how many
    frameless polls (session not running) are tolerated, for tests.
    ``telemetry`` is filled as frames are made (pass one to keep what was
    measured when the loop is interrupted: issue 23 item 5). ``offline``: no
    stall guard, and the simulation runs on to ``duration`` after the last
    frame taken before it (module docstring).
    """
    tick = clock  # type: ignore[assignment]
    tel = telemetry if telemetry is not None else Telemetry(backend=presenter.name)
    origin: float | None = None
    last_display: float | None = None
    while not presenter.closed:
        if duration is not None and sim.t >= duration - 1e-9:
            break
        timing = presenter.wait_frame()
        if timing is None:
            tel.idle_polls += 1
            if max_idle_polls is not None and tel.idle_polls > max_idle_polls:
                break
            continue
        if origin is None:
            if not timing.should_render:
                presenter.end_frame()
                continue
            if not offline and sim.step_index == 0:
                sim.step()  # bodies are posed by a step: a live view never shows them unposed at t = 0
            origin = timing.display_time - sim.t
        if offline and duration is not None and timing.display_time - origin >= duration - 1e-9:
            sim.advance_to(duration)  # no frame at or after the end: the run still covers it all
            break
        if last_display is not None:
            interval = timing.display_time - last_display
            tel.frame_ms.append(interval * 1e3)
            tel.missed_frames += missed_between(interval, timing.period)
            tel.refreshes += max(1, int(round(interval / timing.period))) if timing.period > 0 else 1
            tel.period_s = timing.period
        last_display = timing.display_time
        target = timing.display_time - origin
        if duration is not None:
            target = min(target, duration)
        lag = target - sim.t
        if lag > max_lag and not offline:
            origin += lag - max_lag
            tel.skipped_sim_s += lag - max_lag
            target = sim.t + max_lag
        t0 = tick()  # type: ignore[operator]
        before = sim.step_index
        sim.advance_to(target)
        t1 = tick()  # type: ignore[operator]
        if timing.should_render:
            presenter.render(sim)
        presenter.end_frame()
        t2 = tick()  # type: ignore[operator]
        tel.sim_ms.append((t1 - t0) * 1e3)
        tel.render_ms.append((t2 - t1) * 1e3)
        tel.steps.append(sim.step_index - before)
    return tel
