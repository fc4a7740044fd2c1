"""The frame loop: fixed simulation steps decoupled from the display, display time drives the clock."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation
from pedvr.xr.loop import FrameTiming, missed_between, missed_line, run_frames


@dataclass
class ScriptedPresenter:
    """Display times from a list; records the simulation time of each rendered frame."""

    times: list[float]
    period: float
    name: str = "fake"
    shown: list[float] = field(default_factory=list)
    renders: int = 0
    ends: int = 0

    @property
    def closed(self) -> bool:
        return not self.times

    def wait_frame(self) -> FrameTiming | None:
        return FrameTiming(display_time=self.times.pop(0), period=self.period)

    def render(self, sim: Simulation) -> None:
        self.renders += 1
        self.shown.append(sim.t)

    def end_frame(self) -> None:
        self.ends += 1

    def close(self) -> None:
        pass


@pytest.fixture(scope="module")
def scene():  # type: ignore[no-untyped-def]
    return load_any(resolve_scene("headon_corridor"), seed=None)


def test_simulation_follows_display_time_at_its_own_fixed_dt(scene) -> None:  # type: ignore[no-untyped-def]
    sim = Simulation(scene)
    dt = sim.dt
    # A 60 Hz display starting at an arbitrary runtime time: 1.5 steps of 1/90 s per frame on average.
    times = [1000.0 + k / 60 for k in range(31)]
    p = ScriptedPresenter(times=list(times), period=1 / 60)
    tel = run_frames(sim, p, duration=None)
    assert p.renders == 31 and tel.missed_frames == 0
    # The first frame shows the world after its first step (the bodies posed), at t = dt.
    assert sim.t == pytest.approx(dt + 30 / 60, abs=dt)
    for k, shown in enumerate(p.shown):
        assert dt + k / 60 - dt - 1e-9 <= shown <= dt + k / 60 + 1e-9  # never ahead, < one step behind
    assert set(tel.steps[1:]) <= {1, 2}


def test_missed_frames_are_counted_from_the_display_intervals(scene) -> None:  # type: ignore[no-untyped-def]
    times = [0.0, 1 / 90, 2 / 90, 5 / 90, 6 / 90]  # two refreshes missed between the 3rd and 4th frame
    tel = run_frames(Simulation(scene), ScriptedPresenter(times=times, period=1 / 90), duration=None)
    assert tel.missed_frames == 2 and tel.refreshes == 6
    assert missed_between(1 / 90, 1 / 90) == 0 and missed_between(3.1 / 90, 1 / 90) == 2


def test_missed_frames_are_reported_with_their_cause() -> None:
    """The desktop on llvmpipe missed 799 refreshes and said only that; the line says of how
    many, what was too slow, and that a software renderer says nothing about a GPU."""
    s = {"missed_frames": 799, "display_refreshes": 900, "refresh_ms": 16.667, "render_ms_p50": 70.2,
         "sim_ms_p50": 0.9}
    line = missed_line(s, "llvmpipe (LLVM 15.0.6, 256 bits)")
    assert line == ("missed 799 of 900 display refreshes (89 %): drawing a frame takes 70.2 ms at p50, "
                    "longer than a 16.667 ms refresh; llvmpipe (LLVM 15.0.6, 256 bits) is a software "
                    "renderer: frame rates need a GPU")
    s.update(missed_frames=0, render_ms_p50=5.0)
    assert missed_line(s, "NVIDIA H100") == "missed 0 of 900 display refreshes (0 %)"


def test_a_stall_skips_simulated_time_instead_of_a_burst_of_steps(scene) -> None:  # type: ignore[no-untyped-def]
    sim = Simulation(scene)
    tel = run_frames(
        sim, ScriptedPresenter(times=[0.0, 1 / 90, 3.0], period=1 / 90), duration=None, max_lag=0.25
    )
    assert sim.t == pytest.approx(sim.dt + 1 / 90 + 0.25, abs=sim.dt)
    assert tel.skipped_sim_s == pytest.approx(3.0 - 1 / 90 - 0.25, abs=1e-9)
    assert max(tel.steps) <= round(0.25 / sim.dt) + 1


def test_duration_stops_the_loop_and_telemetry_goes_into_the_summary(scene) -> None:  # type: ignore[no-untyped-def]
    sim = Simulation(scene)
    p = ScriptedPresenter(times=[k / 30 for k in range(100)], period=1 / 30)
    tel = run_frames(sim, p, duration=1.0)
    assert sim.t == pytest.approx(1.0, abs=1e-9)
    s = tel.summary()
    assert s["frames"] == p.renders and s["fps"] == pytest.approx(30.0)
    assert {"sim_ms_p50", "render_ms_p50", "missed_frames", "frame_ms_p95"} <= set(s)


def test_offline_frames_are_taken_at_k_over_fps_and_none_at_or_after_the_end(scene) -> None:  # type: ignore[no-untyped-def]
    """Issue 24 item 11: --fps 1 --duration 6 wrote 26 frames (the stall guard moved the clock by
    0.25 s a frame); offline, frame k shows simulated time k/fps and the run still reaches 6 s."""
    sim = Simulation(scene)
    p = ScriptedPresenter(times=[float(k) for k in range(100)], period=1.0)
    tel = run_frames(sim, p, duration=6.0, offline=True)
    assert p.renders == 6 and tel.skipped_sim_s == 0
    for k, shown in enumerate(p.shown):
        assert k - sim.dt - 1e-9 <= shown <= k + 1e-9
    assert sim.t == pytest.approx(6.0, abs=1e-9)


def test_interrupted_loop_keeps_the_telemetry_measured_so_far(scene) -> None:  # type: ignore[no-untyped-def]
    """Issue 23 item 5: Ctrl-C in the frame loop dropped the telemetry ('frames 0 ... p50 None')."""
    from pedvr.xr.loop import Telemetry

    class Interrupting(ScriptedPresenter):
        def wait_frame(self) -> FrameTiming | None:
            if self.renders == 5:
                raise KeyboardInterrupt
            return super().wait_frame()

    tel = Telemetry(backend="fake")
    with pytest.raises(KeyboardInterrupt):
        run_frames(Simulation(scene), Interrupting(times=[k / 90 for k in range(50)], period=1 / 90),
                   duration=None, telemetry=tel)
    s = tel.summary()
    assert s["frames"] == 5 and s["render_ms_p50"] is not None and s["frame_ms_max"] is not None


def test_the_clock_starts_at_the_first_frame_that_is_drawn(scene) -> None:  # type: ignore[no-untyped-def]
    """An OpenXR session sends frames it will not show (not yet visible): the world waits for them, so
    the participant's first view is the scene at t = 0, seed for seed the same."""

    @dataclass
    class Hidden(ScriptedPresenter):
        hidden: int = 3

        def wait_frame(self) -> FrameTiming | None:
            t = self.times.pop(0)
            show = self.ends >= self.hidden
            return FrameTiming(display_time=t, period=self.period, should_render=show)

    sim = Simulation(scene)
    p = Hidden(times=[k / 90 for k in range(10)], period=1 / 90)
    run_frames(sim, p, duration=None)
    assert p.ends == 10 and p.renders == 7 and p.shown[0] == pytest.approx(sim.dt)  # one step: posed bodies
    assert sim.t == pytest.approx(sim.dt + 6 / 90, abs=1e-9)
