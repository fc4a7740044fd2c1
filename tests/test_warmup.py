"""A cold first run compiles its scene's kernels in a second process, with the types its step uses,
all but the pose graph's (which its own set-up compiles), and waits for it before its first step;
``pedvr prepare`` compiles a scene's first steps (issue 27 goal 2)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pedvr import prepare, warmup
from pedvr.cli import main
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

_SIGNATURES = """
import importlib, pkgutil
from numba.core.registry import CPUDispatcher
import pedvr

def signatures():
    out = {}
    for m in pkgutil.walk_packages(pedvr.__path__, "pedvr."):
        if m.name.split(".")[1] in ("render", "xr", "study", "sweep") or m.name.endswith("__main__"):
            continue
        mod = importlib.import_module(m.name)
        for name, v in vars(mod).items():
            if isinstance(v, CPUDispatcher):
                out[f"{mod.__name__}.{name}"] = {str(s) for s in v.signatures}
    return out
"""

_AFTER_WARM_UP = _SIGNATURES + """
import json, sys
from pedvr import warmup
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

runs = (("antipodal_circle", "pedvr+g"), ("door_double", "pedvr"))
for name, condition in runs:
    warmup.scene_kernels(name, condition)
before = signatures()
for name, condition in runs:
    sim = Simulation(load_any(resolve_scene(name), seed=None), condition=condition)
    for _ in range(6):
        sim.step()
print(json.dumps(sorted(k for k, v in signatures().items() if v - before.get(k, set()))))
"""


def test_the_warm_up_compiles_every_kernel_a_step_uses_but_the_pose_graph_with_the_steps_types() -> None:
    """In a fresh process, after :func:`warmup.scene_kernels` (what ``python -m pedvr.warmup`` does)
    for two scenes, building and stepping those scenes adds a specialisation to one kernel only,
    the pose graph's, which a run's own set-up compiles (a different array type anywhere else would
    compile a second one in the run, beside or after the warm-up, defeating it)."""
    res = subprocess.run([sys.executable, "-c", _AFTER_WARM_UP], capture_output=True, text=True,
                         timeout=1200, check=False)
    assert res.returncode == 0, res.stderr[-3000:]
    assert json.loads(res.stdout.strip().splitlines()[-1]) == ["pedvr.body.graph._pose_rows"]


class _Running:
    def poll(self) -> None:
        return None  # still compiling


class _FakeWarmer:
    def __init__(self, log: list[str]) -> None:
        self.log = log
        self.proc = _Running()

    def wait(self) -> bool:
        self.log.append("wait")
        return True

    def stop(self) -> None:
        self.log.append("stop")


def test_first_step_waits_for_the_second_process_before_it_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    log: list[str] = []
    sim = Simulation(load_any(resolve_scene("antipodal_circle"), seed=None))
    step = sim.step

    def logged() -> None:
        log.append("step")
        step()

    monkeypatch.setattr(sim, "step", logged)
    monkeypatch.setattr(warmup, "started", _FakeWarmer(log))
    said: list[str] = []
    prepare.first_step(sim, say=said.append, warmer=warmup.take())
    assert log == ["wait", "step", "stop"]
    assert any("second process" in line for line in said)
    assert warmup.started is None  # handed over once
    sim.step()  # later steps do not wait
    assert log == ["wait", "step", "stop", "step"]


def test_cold_reads_numbas_cache(tmp_path: Path) -> None:
    """An empty cache folder is cold; this checkout's (warm from the tests above) is not."""
    code = "from pedvr import warmup; print(warmup.cold())"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    cold = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert cold.stdout.strip() == "True", cold.stderr
    assert warmup.cold() is False  # the pose graph and gait were loaded or compiled above


def test_cli_prepare_says_what_it_prepares_and_bad_scenes_are_one_line(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["prepare"]) == 0
    err = capsys.readouterr().err
    assert "preparing antipodal_circle (pedvr+g)" in err and "prepared antipodal_circle in" in err
    assert main(["prepare", "antipodal_circle", "nosuchscene"]) == 2
    assert capsys.readouterr().err.strip() == "pedvr: error: nosuchscene: no such scene file"


_AFTER_PREPARE = _SIGNATURES + """
from pedvr.cli import DEFAULT_SCENE, main
from pedvr.headless import simulate
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene

assert main(["prepare"]) == 0
before = signatures()
simulate(load_any(resolve_scene(DEFAULT_SCENE), seed=None), duration=None, seed=None, condition="pedvr+g",
         responsibility=None, record=True)
new = {k: sorted(v - before.get(k, set())) for k, v in signatures().items() if v - before.get(k, set())}
print(sum(bool(v) for v in before.values()), new)
"""


def test_a_run_after_pedvr_prepare_needs_no_kernel_it_did_not_prepare() -> None:
    """Issue 27 goal 2: the README's set-up runs ``pedvr prepare`` so that the first ``pedvr run``
    loads every kernel from numba's cache. In a fresh process, after ``pedvr prepare``, the default
    scene's whole run (as ``pedvr run`` steps it headless) adds no specialisation to any kernel of
    the simulation's layers: none would compile during a run that follows a cold ``pedvr prepare``."""
    res = subprocess.run([sys.executable, "-c", _AFTER_PREPARE], capture_output=True, text=True,
                         timeout=1200, check=False, env={**os.environ, "PYTHONHASHSEED": "0"})
    assert res.returncode == 0, res.stderr[-3000:]
    prepared, new = res.stdout.strip().splitlines()[-1].split(" ", 1)
    assert int(prepared) > 40  # the crowd's, the world's, the body's kernels were there before the run
    assert new == "{}", new
