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


def _imports() -> dict[str, set[str]]:
    """pedvr's modules and the pedvr modules each imports, lazily (inside functions) or not."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "pedvr"
    graph: dict[str, set[str]] = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        name = ".".join(parts)
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("pedvr"):
                deps.add(node.module)
                deps.update(f"{node.module}.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names if a.name.startswith("pedvr"))
        graph[name] = deps
    return {m: {d for d in deps if d in graph and d != m} for m, deps in graph.items()}


def test_the_run_modules_import_no_circle() -> None:
    """Issue 24, the house: pedvr/headless.py and pedvr/xr/run.py imported each other (two modules
    named headless). The backends, the headless entry point, preparing and a run's files form no
    import circle (lazy imports inside functions count)."""
    graph = _imports()
    ours = {m for m in graph if m.startswith("pedvr.xr") or m in ("pedvr.headless", "pedvr.outputs",
                                                                     "pedvr.prepare")}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles: list[set[str]] = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1 and comp & ours:
                circles.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert circles == [], f"import circles through the run modules: {circles}"
    assert not any(m.endswith(".headless") for m in graph if m.startswith("pedvr.xr"))  # one headless
