"""GLSL programs from files in ``shaders/``: includes, stage guards, errors naming file, stage and line.

One program per file. A file holds every stage, each inside a guard
(``#ifdef VERTEX_SHADER`` / ``#ifdef FRAGMENT_SHADER``), and may pull in
shared code with ``#include "common.glsl"`` (recursive; a file is included once
per stage at most, cycles are an error). For each stage the loader prepends
``#version 330 core`` and the stage's define, and inserts ``#line`` directives
with a source-string number per file, so the driver's log points into the
right file; :func:`compile_program` turns that log into
``shaders/crowd.glsl: fragment stage, line 12: ...`` lines (the moderngl-window
habit, STYLE.md).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pedvr.errors import PedvrError

if TYPE_CHECKING:
    import moderngl

def _shader_dir() -> Path:
    """The source tree's ``shaders/``, else the installed copy under ``sys.prefix``."""
    import sys

    here = Path(__file__).resolve().parents[2] / "shaders"
    return here if here.is_dir() else Path(sys.prefix) / "share" / "pedvr" / "shaders"


SHADER_DIR = _shader_dir()
GLSL_VERSION = "#version 330 core"
STAGES = {"vertex": "VERTEX_SHADER", "geometry": "GEOMETRY_SHADER", "fragment": "FRAGMENT_SHADER"}

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
# Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error ..."; AMD/Intel: "ERROR: 0:12: ...".
_LOG_LINE = re.compile(r"(?:ERROR:\s*|WARNING:\s*)?(\d+)[:(](\d+)\)?(?:\(\d+\))?\s*:\s*(.*)")


class ShaderError(PedvrError):
    """A GLSL program failed to load or compile; one line per problem: ``file: stage, line N: message``."""

    exit_code = 4


@dataclass(frozen=True)
class StageSource:
    """One stage's expanded source and the files its source-string numbers refer to."""

    stage: str
    text: str
    files: tuple[Path, ...]


def expand(path: Path, *, stage: str, shader_dir: Path = SHADER_DIR) -> StageSource:
    """The source of ``stage`` of the program in ``path``, includes expanded, ``#line`` directives in."""
    if stage not in STAGES:
        raise ShaderError(f"{path}: unknown stage {stage!r}; known: {', '.join(STAGES)}")
    files: list[Path] = []
    out: list[str] = [GLSL_VERSION, f"#define {STAGES[stage]} 1"]

    def emit(p: Path, chain: tuple[Path, ...]) -> None:
        if p in chain:
            raise ShaderError(f"{chain[-1]}: include cycle: {' -> '.join(str(c.name) for c in chain + (p,))}")
        try:
            text = p.read_text()
        except OSError as exc:
            where = f"{chain[-1]}: " if chain else ""
            raise ShaderError(f"{where}cannot read shader file {p}: {exc.strerror}") from None
        index = len(files)
        files.append(p)
        # GLSL 3.30: after "#line L S" the next line is line L (Mesa, NVIDIA and AMD agree in core 330).
        out.append(f"#line 1 {index}")
        for lineno, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m is None:
                if line.lstrip().startswith("#version"):
                    raise ShaderError(f"{p}: line {lineno}: no #version in shader files (the loader adds it)")
                out.append(line)
                continue
            target = (p.parent / m.group(1)).resolve()
            if not target.is_relative_to(shader_dir.resolve()) and not target.is_relative_to(
                p.parent.resolve()
            ):
                raise ShaderError(f"{p}: line {lineno}: include {m.group(1)!r} is outside {shader_dir}")
            emit(target, chain + (p,))
            out.append(f"#line {lineno + 1} {index}")

    emit(path, ())
    return StageSource(stage=stage, text="\n".join(out) + "\n", files=tuple(files))


def stages_in(path: Path) -> tuple[str, ...]:
    """The stages a program file defines (by its guards, includes not counted)."""
    text = path.read_text()
    found = tuple(
        s for s, define in STAGES.items() if re.search(rf"#if(?:def)?\s+(?:defined\s*\(?\s*)?{define}", text)
    )
    if "vertex" not in found or "fragment" not in found:
        raise ShaderError(f"{path}: needs both #ifdef VERTEX_SHADER and #ifdef FRAGMENT_SHADER sections")
    return found


def describe_log(log: str, *, stage: str, files: tuple[Path, ...]) -> list[str]:
    """Driver log lines mapped to ``file: stage, line N: message``; unparsed lines keep the program file."""
    out = []
    for raw in log.splitlines():
        raw = raw.strip()
        if not raw:
            continue
        m = _LOG_LINE.match(raw)
        if m is not None and int(m.group(1)) < len(files):
            out.append(f"{_rel(files[int(m.group(1))])}: {stage} stage, line {m.group(2)}: {m.group(3)}")
        else:
            out.append(f"{_rel(files[0])}: {stage} stage: {raw}")
    return out


def _rel(p: Path) -> str:
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def compile_program(ctx: moderngl.Context, name: str, *, shader_dir: Path = SHADER_DIR) -> moderngl.Program:
    """Compile ``shader_dir/name`` (e.g. ``"crowd.glsl"``) into a program; raise :class:`ShaderError`."""
    import moderngl

    path = shader_dir / name
    if not path.is_file():
        known = ", ".join(sorted(p.name for p in shader_dir.glob("*.glsl")))
        raise ShaderError(f"{path}: no such shader file; known: {known}")
    sources = {s: expand(path, stage=s, shader_dir=shader_dir) for s in stages_in(path)}
    # Compile each stage alone first: moderngl reports only the first failing
    # stage, and mixes stage names into its message; a lone shader object gives a clean log.
    problems: list[str] = []
    for stage, src in sources.items():
        log = _stage_log(ctx, stage, src.text)
        if log is not None:
            problems.extend(describe_log(log, stage=stage, files=src.files))
    if problems:
        raise ShaderError("\n".join(problems))
    try:
        return ctx.program(
            vertex_shader=sources["vertex"].text,
            fragment_shader=sources["fragment"].text,
            geometry_shader=sources["geometry"].text if "geometry" in sources else None,
        )
    except moderngl.Error as exc:  # link errors: no line to point at
        lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip() and not set(ln.strip()) <= {"="}]
        raise ShaderError("\n".join(f"{_rel(path)}: link: {ln}" for ln in lines)) from None


def _stage_log(ctx: moderngl.Context, stage: str, text: str) -> str | None:
    """The compile log of one stage, or None when it compiles.

    moderngl has no public per-stage compile; a program with only that stage
    (plus a trivial partner) isolates the stage's log.
    """
    import moderngl

    trivial_vs = f"{GLSL_VERSION}\nvoid main() {{ gl_Position = vec4(0.0); }}\n"
    trivial_fs = f"{GLSL_VERSION}\nout vec4 f;\nvoid main() {{ f = vec4(0.0); }}\n"
    if stage == "geometry":
        return None  # compiled with the real program; geometry stages need their vertex partner
    vs, fs = (text, trivial_fs) if stage == "vertex" else (trivial_vs, text)
    try:
        prog = ctx.program(vertex_shader=vs, fragment_shader=fs)
    except moderngl.Error as exc:
        msg = str(exc)
        if "GLSL Compiler failed" not in msg:
            return None  # a link-only problem of the isolated stage: reported by the full link
        body = msg.split("=" * 5)[-1] if "=" * 5 in msg else msg
        return body.strip("= \n") or msg
    prog.release()
    return None


def shader_files(shader_dir: Path = SHADER_DIR) -> list[Path]:
    """Every program file (files that are only included, like ``common.glsl``, excluded)."""
    return sorted(p for p in shader_dir.glob("*.glsl") if re.search(r"\bvoid\s+main\s*\(", p.read_text()))


def set_uniform(prog: moderngl.Program, name: str, value: object) -> None:
    """Set a uniform's value (uniforms the compiler removed are skipped: they cannot matter)."""
    import moderngl

    if name in prog:
        u = prog[name]
        assert isinstance(u, moderngl.Uniform), f"{name} is not a uniform"
        u.value = value
