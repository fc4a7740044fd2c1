"""Preparing a run (issue 25 item 13, issue 23 item 2): the first step says what numba compiles, with
progress; frame-loop backends step a simulation of their own with both kernel twins and draw once."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from numba import njit

from pedvr.prepare import CompileLog, first_step, prepare
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import PHASES, Simulation


@dataclass
class _Metrics:
    phase_ms: dict[str, float] = field(default_factory=dict)


class CompilingSim:
    """A stand-in for a simulation whose 'avoid' phase calls kernels numba has never compiled (made
    per instance, no cache), as a fresh install's first step does."""

    def __init__(self) -> None:
        self.metrics = _Metrics()
        self.steps = 0

        def orca_rows(x):  # type: ignore[no-untyped-def]
            return x * 2.0 + 1.0

        def body_pose(x):  # type: ignore[no-untyped-def]
            return x.sum()

        self.kernels = {"avoid": njit(cache=False)(orca_rows), "animate": njit(cache=False)(body_pose)}

    def step(self) -> None:
        for name in PHASES:
            if name in self.kernels:
                self.kernels[name](np.ones(3))
            self.metrics.phase_ms[name] = self.metrics.phase_ms.get(name, 0.0) + 0.1
        self.steps += 1


def test_the_first_step_says_which_phase_and_kernel_numba_compiles() -> None:
    lines: list[str] = []
    sim = CompilingSim()
    out = first_step(sim, say=lines.append)  # type: ignore[arg-type]
    assert out.kernels_compiled == 2 and out.compile_s > 0 and sim.steps == 1
    text = "\n".join(lines)
    assert lines[0].startswith("preparing: numba is compiling pedvr's kernels")
    assert "step phase 'avoid': compiling" in text and "step phase 'animate': compiling" in text
    assert "orca_rows" in text  # the first kernel is always named (progress lines are rate-limited)
    assert lines[-1].startswith("preparing: 2 kernels compiled in")
    assert set(out.phase_s) == set(PHASES)


def test_a_warm_first_step_is_silent_and_prepare_says_one_line_before_and_one_after() -> None:
    scene = load_any(resolve_scene("headon_corridor"), seed=None)
    prepare(lambda: Simulation(scene), what="warming", say=None)  # compiled (or loaded from the cache) now
    lines: list[str] = []
    drawn: list[Simulation] = []
    out = prepare(lambda: Simulation(scene), what="headon_corridor (test)", draw=drawn.append,
                  say=lines.append)
    assert len(drawn) == 1 and drawn[0].step_index == 1 + 2 * 4 + 1  # first step, 4 with each twin, 1 turned
    assert lines[0] == "preparing headon_corridor (test): the first step and the first frame ..."
    assert lines[-1].startswith("prepared in ") and "0 kernels compiled" in lines[-1]
    assert len(lines) == 2
    s = out.summary()
    assert s["kernels_compiled"] == 0 and s["first_draw_s"] is not None


def test_preparing_does_not_touch_the_run() -> None:
    """The run's own simulation starts at t = 0 and gives the same bytes as without preparing."""
    scene = load_any(resolve_scene("headon_corridor"), seed=None)
    a = Simulation(scene)
    prepare(lambda: Simulation(scene), what="x", say=None)
    b = Simulation(scene)
    for sim in (a, b):
        sim.advance_to(0.5)
    assert a.crowd.pos.tobytes() == b.crowd.pos.tobytes() and a.t == b.t


def test_compile_log_names_kernels_compiled_inside_it() -> None:
    @njit(cache=False)
    def late_kernel(x):  # type: ignore[no-untyped-def]
        return x + 1

    with CompileLog() as log:
        late_kernel(1.0)
    assert log.names and log.names[0].endswith("late_kernel")
    with CompileLog() as again:
        late_kernel(2.0)
    assert again.names == []


@pytest.mark.parametrize("quiet", [False, True])
def test_pedvr_run_headless_says_nothing_extra_when_warm(quiet: bool, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from pedvr.cli import main

    args = ["run", "headon_corridor", "--duration", "0.1", "--out", str(tmp_path)]
    assert main(args + (["--quiet"] if quiet else [])) == 0
    err = capsys.readouterr().err
    assert "preparing" not in err  # warm: numba loads every kernel from its cache


def test_preparing_reaches_the_turned_footprint_kernels() -> None:
    """Against Monado on a loaded machine a 4 s frame came from a kernel first compiled mid-run: the
    wall distance of turned shoulders (nobody squeezes past anyone in a scene's first steps)."""
    import subprocess
    import sys

    code = (
        "from pedvr.crowd import footprint\n"
        "from pedvr.prepare import prepare\n"
        "from pedvr.scene.loader import load_any\n"
        "from pedvr.scenes import resolve_scene\n"
        "from pedvr.sim import Simulation\n"
        "scene = load_any(resolve_scene('antipodal_circle'), seed=None)\n"
        "before = len(footprint.wall_distance_kernel.signatures)\n"
        "prepare(lambda: Simulation(scene), what='x', say=None)\n"
        "print(before, len(footprint.wall_distance_kernel.signatures))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["0", "1"]  # not compiled (or loaded) before preparing; ready after
