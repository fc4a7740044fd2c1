"""The study room has no import circle (issue 24, "the house"): read from the source with ast, every import
counts, including those inside functions and under ``if TYPE_CHECKING``."""

from __future__ import annotations

import ast
from pathlib import Path

STUDY = Path(__file__).resolve().parents[2] / "pedvr" / "study"
PACKAGE = "pedvr.study"


def import_graph(folder: Path, package: str) -> dict[str, set[str]]:
    """``{module: modules of the same package it imports}`` (the package's ``__init__`` left out: importing
    ``pedvr.study.x`` runs it, but it imports only the errors, so it cannot close a circle)."""
    modules = {f"{package}.{p.stem}" for p in folder.glob("*.py") if p.stem != "__init__"}
    graph: dict[str, set[str]] = {}
    for p in sorted(folder.glob("*.py")):
        if p.stem == "__init__":
            continue
        name = f"{package}.{p.stem}"
        deps: set[str] = set()
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"), filename=str(p))):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # relative: from . import x / from .x import y
                    base = ".".join([package, base]).rstrip(".")
                deps.add(base)
                deps.update(f"{base}.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[name] = (deps & modules) - {name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted."""
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


def test_the_study_package_has_no_import_circle() -> None:
    graph = import_graph(STUDY, PACKAGE)
    assert len(graph) > 15  # the whole room was read
    assert cycles(graph) == []


def test_the_questionnaire_vocabulary_imports_nothing_of_its_room() -> None:
    assert import_graph(STUDY, PACKAGE)[f"{PACKAGE}.instrument"] == set()


def test_the_check_finds_a_circle(tmp_path: Path) -> None:
    """The check itself can fail: a circle through a TYPE_CHECKING import and a function-local one."""
    room = tmp_path / "room"
    room.mkdir()
    (room / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from room.b import B\n")
    (room / "b.py").write_text("def f():\n    from room import c\n")
    (room / "c.py").write_text("from .a import A\n")
    (room / "d.py").write_text("import room.a\n")
    assert cycles(import_graph(room, "room")) == [["room.a", "room.b", "room.c"]]
