"""The etiquette room has no import circles (issue 24, "the house"): every import among its modules
counts, at module level, inside functions and under ``TYPE_CHECKING`` alike, and the shared
vocabulary (``vocab``) imports nothing of the room."""

from __future__ import annotations

import ast
from pathlib import Path

import pedvr.etiquette

ROOM = "pedvr.etiquette"
HERE = Path(pedvr.etiquette.__file__).resolve().parent


def _modules() -> dict[str, Path]:
    out = {ROOM: HERE / "__init__.py"}
    for p in sorted(HERE.glob("*.py")):
        if p.name != "__init__.py":
            out[f"{ROOM}.{p.stem}"] = p
    return out


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The room's modules ``path`` imports, wherever the import statement stands."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in modules)
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            if node.module == ROOM:  # from pedvr.etiquette import decision (a module) or a name
                for a in node.names:
                    out.add(f"{ROOM}.{a.name}" if f"{ROOM}.{a.name}" in modules else ROOM)
            elif node.module in modules:
                out.add(node.module)
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {m: _imports(p, modules) - {m} for m, p in modules.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (found := visit(n)) is not None:
                return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (found := visit(m)) is not None:
            return found
    return None


def test_the_etiquette_room_has_no_import_circle() -> None:
    graph = _graph()
    assert f"{ROOM}.system" in graph and f"{ROOM}.interaction" in graph[f"{ROOM}.system"]  # the scan sees imports
    assert _cycle(graph) is None, " -> ".join(_cycle(graph) or [])


def test_the_vocabulary_imports_nothing_of_its_room() -> None:
    assert _graph()[f"{ROOM}.vocab"] == set()


def test_the_check_finds_a_circle() -> None:
    """The check itself: a circle through a function-level import is found."""
    graph = _graph()
    graph[f"{ROOM}.vocab"] = {f"{ROOM}.system"}
    assert _cycle(graph) is not None
