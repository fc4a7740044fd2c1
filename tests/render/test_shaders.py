"""Every program compiles on Mesa llvmpipe; errors name file, stage and line."""

from __future__ import annotations

from pathlib import Path

import moderngl
import pytest

from pedvr.render.shaders import SHADER_DIR, ShaderError, compile_program, expand, shader_files

PROGRAMS = [p.name for p in shader_files()]


def test_the_shader_folder_holds_every_program() -> None:
    assert {
        "crowd.glsl",
        "environment.glsl",
        "shadow.glsl",
        "overlay.glsl",
        "discs.glsl",
        "panel.glsl",
        "composite.glsl",
    } <= set(PROGRAMS)
    assert "common.glsl" not in PROGRAMS  # an include, not a program


@pytest.mark.parametrize("name", PROGRAMS)
def test_every_program_compiles_and_links(ctx: moderngl.Context, name: str) -> None:
    prog = compile_program(ctx, name)
    assert isinstance(prog, moderngl.Program)
    prog.release()


def _write(d: Path, name: str, text: str) -> None:
    (d / name).write_text(text)


PROGRAM = """\
#include "inc.glsl"
#ifdef VERTEX_SHADER
in vec3 in_pos;
void main() { gl_Position = vec4(in_pos * helper(), 1.0); }
#endif
#ifdef FRAGMENT_SHADER
out vec4 f;
void main() {
    f = vec4(1.0);
    BROKEN_FRAGMENT
}
#endif
"""


def test_error_in_the_program_names_file_stage_and_line(ctx: moderngl.Context, tmp_path: Path) -> None:
    _write(tmp_path, "inc.glsl", "float helper() {\n    return 1.0;\n}\n")
    _write(tmp_path, "p.glsl", PROGRAM.replace("BROKEN_FRAGMENT", "undefined_thing = 2.0;"))
    with pytest.raises(ShaderError, match=r"p\.glsl: fragment stage, line 10: .*undefined_thing"):
        compile_program(ctx, "p.glsl", shader_dir=tmp_path)


def test_error_in_an_include_names_the_include(ctx: moderngl.Context, tmp_path: Path) -> None:
    _write(tmp_path, "inc.glsl", "float helper() {\n    return 1.0 +;\n}\n")
    _write(tmp_path, "p.glsl", PROGRAM.replace("BROKEN_FRAGMENT", ""))
    with pytest.raises(ShaderError) as err:
        compile_program(ctx, "p.glsl", shader_dir=tmp_path)
    lines = str(err.value).splitlines()
    assert any("inc.glsl: vertex stage, line 2:" in ln for ln in lines), lines
    assert any("inc.glsl: fragment stage, line 2:" in ln for ln in lines), lines  # both stages include it


def test_include_cycle_missing_file_and_missing_stage_are_clear(
    ctx: moderngl.Context, tmp_path: Path
) -> None:
    _write(tmp_path, "a.glsl", '#include "b.glsl"\n')
    _write(tmp_path, "b.glsl", '#include "a.glsl"\n')
    with pytest.raises(ShaderError, match=r"include cycle: a\.glsl -> b\.glsl -> a\.glsl"):
        expand(tmp_path / "a.glsl", stage="vertex", shader_dir=tmp_path)
    with pytest.raises(ShaderError, match=r"nope\.glsl: no such shader file; known: a\.glsl, b\.glsl"):
        compile_program(ctx, "nope.glsl", shader_dir=tmp_path)
    _write(tmp_path, "v.glsl", "#ifdef VERTEX_SHADER\nvoid main() {}\n#endif\n")
    with pytest.raises(ShaderError, match=r"needs both #ifdef VERTEX_SHADER and #ifdef FRAGMENT_SHADER"):
        compile_program(ctx, "v.glsl", shader_dir=tmp_path)


def test_expanded_source_keeps_line_numbers_with_line_directives() -> None:
    src = expand(SHADER_DIR / "crowd.glsl", stage="vertex")
    assert src.text.startswith("#version 330 core\n#define VERTEX_SHADER 1\n#line 1 0\n")
    assert [p.name for p in src.files] == ["crowd.glsl", "common.glsl", "skinning.glsl"]
