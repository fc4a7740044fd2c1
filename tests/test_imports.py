"""The house's shape (DESIGN.md "Layout", issue 24 "the house"): no import circle anywhere in pedvr, and
rooms import only the rooms below them.

Read from the source with ast, so every import counts, including those inside functions and under
``if TYPE_CHECKING``: a lazy import that closes a circle is still a circle, it only fails later.
``from pedvr.x import y`` where ``pedvr.x.y`` is a module is an import of that module; importing a
submodule runs its package's ``__init__`` too, but that is the package's own business and is not a
dependency of the importer on the package's other modules.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PEDVR = Path(__file__).resolve().parents[1] / "pedvr"

# DESIGN.md's order, bottom to top: `cli -> xr/study -> render -> sim -> (behavior, etiquette, demonstrator)
# -> (body, crowd) -> world -> scene`, with the modules DESIGN does not draw placed where they sit.
RANK = {
    # the vocabulary everyone shares
    "pedvr": 0, "errors": 0, "registry": 0, "kernels": 0, "validation": 0, "provenance": 0, "scenes": 0,
    "signals": 0, "argtypes": 0,
    "scene": 1,
    "world": 2,
    "body": 3, "crowd": 3,
    "behavior": 4, "etiquette": 4, "demonstrator": 4,
    "sim": 5, "record": 5, "inflow": 5,
    "render": 6, "measure": 6, "prepare": 6, "warmup": 6, "outputs": 6,
    "xr": 7, "study": 7, "headless": 7,
    "sweep": 8, "bench_sim": 8, "benchload": 8,
    "cli": 9, "__main__": 9,
}
# Benchmarks live beside what they measure but drive whole simulations: they sit with the tools.
TOOL_RANK = 8

# Upward imports the design accepts, each with its reason. A new one fails the test until it is argued here.
ALLOWED_UP = {
    # The scene loader validates every name a scene file uses against the registries that the behavior
    # and demonstrator rooms fill (goal selectors, trees, smart objects, the exhibit): a scene is checked
    # whole at load (STYLE.md 10), and the registries are those rooms' extension points (STYLE.md 6).
    ("pedvr.scene.loader", "pedvr.behavior.declare"),
    ("pedvr.scene.loader", "pedvr.behavior.goals"),
    ("pedvr.scene.loader", "pedvr.demonstrator"),
    # The scene's behavior tables are typed by the behavior room's plain data classes.
    ("pedvr.scene.config", "pedvr.behavior.spec"),
    # An avatar file is checked at load against the skeleton's joint names (plain data, numpy only).
    ("pedvr.scene.avatars", "pedvr.body.skeleton"),
}


def _modules() -> dict[str, Path]:
    out = {}
    for p in PEDVR.rglob("*.py"):
        parts = list(p.relative_to(PEDVR.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def import_graph() -> dict[str, set[str]]:
    """``{module: pedvr modules it imports}`` over the whole package."""
    mods = _modules()
    graph: dict[str, set[str]] = {}
    for name, p in mods.items():
        package = name if p.name == "__init__.py" else name.rpartition(".")[0]
        deps: set[str] = set()
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"), filename=str(p))):
            if isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(up + ([base] if base else []))
                deps.update(f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names)
        graph[name] = (deps & set(mods)) - {name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def rank(module: str) -> int:
    parts = module.split(".")
    if parts[-1] == "bench" or parts[-1].startswith("bench_"):
        return TOOL_RANK
    room = parts[1] if len(parts) > 1 else "pedvr"
    if room not in RANK:
        raise AssertionError(f"{module}: a room DESIGN.md's layering does not place; add it to RANK")
    return RANK[room]


def test_no_import_circle_anywhere_in_pedvr() -> None:
    graph = import_graph()
    assert len(graph) > 150  # the whole package was read
    assert cycles(graph) == []


def test_rooms_import_only_rooms_below_them() -> None:
    graph = import_graph()
    up = sorted((m, d) for m, deps in graph.items() for d in deps
                if rank(d) > rank(m) and (m, d) not in ALLOWED_UP)
    assert up == [], "upward imports: " + ", ".join(f"{m} -> {d}" for m, d in up)
    stale = sorted(e for e in ALLOWED_UP if e[1] not in graph.get(e[0], set()))
    assert stale == [], f"ALLOWED_UP lists imports that no longer exist: {stale}"


@pytest.mark.parametrize("module", ["pedvr.study.instrument", "pedvr.behavior.state", "pedvr.etiquette.vocab"])
def test_shared_vocabulary_imports_nothing_of_its_room(module: str) -> None:
    room = module.rpartition(".")[0]
    assert {d for d in import_graph()[module] if d.startswith(room + ".") or d == room} == set()


def test_one_headless_entry_point() -> None:
    """Two modules named headless (pedvr/headless.py and pedvr/xr/headless.py) imported each other."""
    assert [m for m in import_graph() if m.rpartition(".")[2] == "headless"] == ["pedvr.headless"]


def test_a_circle_is_found() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
