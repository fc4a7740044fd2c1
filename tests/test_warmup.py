"""A cold first run compiles the body's kernels in a second process, with the types a step uses, and
waits for it before it first poses the bodies; ``pedvr prepare`` compiles a scene's first steps
(issue 27 goal 2)."""

from __future__ import annotations

import importlib
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core.registry import CPUDispatcher

import pedvr.body
from pedvr import prepare, warmup
from pedvr.cli import main
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _body_signatures() -> dict[str, set[str]]:
    out = {}
    for m in pkgutil.iter_modules(pedvr.body.__path__, "pedvr.body."):
        mod = importlib.import_module(m.name)
        for name, v in vars(mod).items():
            if isinstance(v, CPUDispatcher) and v.py_func.__module__ == mod.__name__:
                out[f"{mod.__name__}.{name}"] = {str(s) for s in v.signatures}
    return out


def test_warm_up_compiles_the_body_kernels_a_step_uses_with_the_steps_types() -> None:
    """After :func:`warmup.body_kernels`, stepping scenes adds no specialisation to any body kernel
    (a different array type would compile a second one, in the run, defeating the warm-up)."""
    warmup.body_kernels()
    before = _body_signatures()
    warmed = {k for k, v in before.items() if v}
    assert {"pedvr.body.graph._pose_rows", "pedvr.body.locomotion.gait_kernel",
            "pedvr.body.actions.agent_model_kernel", "pedvr.body.graph.gaze_rule_kernel"} <= warmed
    for name, condition in (("antipodal_circle", "pedvr+g"), ("antipodal_circle", "pedvr"),
                            ("antipodal_circle", "decoupled")):
        sim = Simulation(load_any(resolve_scene(name), seed=None), condition=condition)
        for _ in range(6):
            sim.step()
    after = _body_signatures()
    assert {k: v - before.get(k, set()) for k, v in after.items() if v - before.get(k, set())} == {}


class _FakeWarmer:
    def __init__(self, log: list[str]) -> None:
        self.log = log
        self.proc = None

    def wait(self) -> bool:
        self.log.append("wait")
        return True

    def stop(self) -> None:
        self.log.append("stop")


def test_first_step_waits_for_the_second_process_before_posing_the_bodies(
        monkeypatch: pytest.MonkeyPatch) -> None:
    log: list[str] = []
    sim = Simulation(load_any(resolve_scene("antipodal_circle"), seed=None))
    compose = sim.body.compose

    def logged(*args: object, **kwargs: object) -> None:
        log.append("compose")
        compose(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(sim.body, "compose", logged)
    monkeypatch.setattr(warmup, "started", _FakeWarmer(log))
    said: list[str] = []
    prepare.first_step(sim, say=said.append)
    assert log == ["wait", "compose", "stop"]
    assert warmup.started is None  # handed over once
    assert any("second process" in line for line in said)
    sim.step()  # later steps do not wait
    assert log == ["wait", "compose", "stop", "compose"]


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


_AFTER_PREPARE = """
import importlib, pkgutil, sys
from numba.core.registry import CPUDispatcher
import pedvr
from pedvr.cli import DEFAULT_SCENE, main
from pedvr.headless import simulate
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene

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
