"""Simulation layers never import moderngl, glfw or xr (DESIGN.md, STYLE.md habit 1)."""

from __future__ import annotations

import subprocess
import sys

SIM_LAYERS = [
    "pedvr.sim",
    "pedvr.scene",
    "pedvr.scene.loader",
    "pedvr.world",
    "pedvr.crowd",
    "pedvr.crowd.steering",
    "pedvr.crowd.user",
    "pedvr.behavior",
    "pedvr.behavior.bfsm",
    "pedvr.etiquette",
    "pedvr.demonstrator",
    "pedvr.body",
    "pedvr.headless",
]


def test_simulation_layers_do_not_import_gl_glfw_or_openxr() -> None:
    code = (
        "import importlib, pkgutil, sys\n"
        f"names = {SIM_LAYERS!r}\n"
        "for n in list(names):\n"
        "    try:\n"
        "        m = importlib.import_module(n)\n"
        "    except ModuleNotFoundError as e:\n"
        "        if e.name == n: continue\n"
        "        raise\n"
        "    for sub in pkgutil.walk_packages(getattr(m, '__path__', []), n + '.'):\n"
        "        importlib.import_module(sub.name)\n"
        "from pedvr.sim import Simulation\n"
        "from pedvr.scene.loader import load_any\n"
        "from pedvr.scenes import resolve_scene\n"
        "Simulation(load_any(resolve_scene('headon_corridor'), seed=None)).advance_to(0.1)\n"
        "bad = sorted(m for m in ('moderngl', 'glfw', 'xr', 'OpenGL', 'glcontext') if m in sys.modules)\n"
        "print(','.join(bad))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "", f"simulation layers imported {r.stdout.strip()}"
