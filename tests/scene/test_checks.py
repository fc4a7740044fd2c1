"""What `pedvr scene check` and the loader say about avatar files and bodies that start overlapping.

Avatar files (issue 25.11) are checked when the scene loads, without GL: a text file named
``.glb``, an empty or truncated ``.glb``, a glTF without a skin, a damaged buffer are each one
problem line naming the profile key and the file. Coincident spawns (issue 24.1) are warnings.
"""

from __future__ import annotations

import json
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from pedvr.cli import main
from pedvr.errors import SceneError
from pedvr.scene.avatars import AvatarError, open_avatar
from pedvr.scene.checks import spawn_warnings
from pedvr.scene.loader import load_scene
from pedvr.scenes import shipped_scenes
from tests.render.gltf_builder import build
from tests.scene.test_loader import patched, write


def _with_avatar(tmp_path: Path, pattern: str) -> Path:
    return write(tmp_path, patched(agents__profiles__adult__characters=["builtin", pattern]))


def _glb_json(raw: bytes) -> dict:
    (n,) = struct.unpack_from("<I", raw, 12)
    return json.loads(raw[20 : 20 + n])


def _glb(doc: dict, blob: bytes) -> bytes:
    """A binary glTF from its JSON and binary chunk (glTF 2.0 §4.4)."""
    js = json.dumps(doc).encode()
    js += b" " * ((-len(js)) % 4)
    blob += b"\0" * ((-len(blob)) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _damaged(good: bytes, change: object) -> bytes:
    """``good`` with its JSON changed by ``change(doc)`` and its binary chunk kept."""
    doc = _glb_json(good)
    (n,) = struct.unpack_from("<I", good, 12)
    (m,) = struct.unpack_from("<I", good, 20 + n)
    blob = good[28 + n : 28 + n + m]
    change(doc)  # type: ignore[operator]
    return _glb(doc, blob)


def _unusable(tmp_path: Path) -> dict[str, tuple[bytes, str]]:
    """File name -> (bytes, the message's pattern): every kind of unusable file the issue names, and more."""
    good = build(tmp_path / "good.glb").read_bytes()

    def drop_skin(doc: dict) -> None:
        for node in doc["nodes"]:
            node.pop("skin", None)

    def big_buffer(doc: dict) -> None:
        doc["buffers"][0]["byteLength"] += 4096

    def far_accessor(doc: dict) -> None:
        doc["accessors"][0]["count"] *= 50

    def bad_joint(doc: dict) -> None:
        doc["skins"][0]["joints"] = doc["skins"][0]["joints"][:3]  # JOINTS_0 names bones up to 24

    return {
        "text.glb": (b"this is a text file, not a model\n",
                     r"not a readable glTF 2\.0 file: a \.glb file is binary glTF and starts with b'glTF'; "
                     r"this one starts with b'this is '"),
        "empty.glb": (b"", r"not a readable glTF 2\.0 file: it is empty \(0 bytes\)"),
        "half.glb": (good[: len(good) // 2],
                     rf"not a readable glTF 2\.0 file: truncated \({len(good) // 2} bytes; its header declares "
                     rf"{len(good)}\)"),
        "stub.glb": (good[:16], r"not a readable glTF 2\.0 file: truncated \(16 bytes; a binary glTF header "
                                r"alone is 20\)"),
        "noskin.glb": (_damaged(good, drop_skin),
                       r"no skin \(pedvr needs a mesh skinned to a humanoid skeleton\)"),
        "short.glb": (_damaged(good, big_buffer), r"buffer 0 holds \d+ bytes; the file declares \d+ \(truncated\?\)"),
        "far.glb": (_damaged(good, far_accessor),
                    r"primitive 0 of mesh 0 POSITION: accessor 0 reaches past the end of its data"),
        "bones.glb": (_damaged(good, bad_joint), r"primitive 0 of mesh 0: JOINTS_0 names bone \d+; the skin has 3"),
        "text.gltf": (b"{not json", r"not a readable glTF 2\.0 file: not glTF JSON \("),
    }


def test_unusable_avatar_files_are_refused_at_load_one_line_each(tmp_path: Path) -> None:
    for name, (data, message) in _unusable(tmp_path).items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(AvatarError, match=rf"{re.escape(name)}: {message}"):
            open_avatar(tmp_path / name)
        with pytest.raises(SceneError) as info:
            load_scene(_with_avatar(tmp_path, name))
        assert len(info.value.problems) == 1, (name, info.value.problems)
        assert re.fullmatch(rf"\S+x\.toml: agents\.profiles\.adult\.characters\[1\] = '{re.escape(name)}': "
                            rf"\S*{re.escape(name)}: ({message}).*", info.value.problems[0]), info.value.problems


def test_a_good_avatar_loads_and_its_file_is_read_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pedvr.scene.loader as loader

    build(tmp_path / "good.glb")
    opened: list[Path] = []
    real = loader.open_avatar
    monkeypatch.setattr(loader, "open_avatar", lambda p, **kw: (opened.append(p), real(p, **kw))[1])
    s = load_scene(_with_avatar(tmp_path, "good.glb"))
    assert s.profiles["child"].characters == s.profiles["adult"].characters  # inherited
    assert s.profiles["adult"].characters[1] == str((tmp_path / "good.glb").resolve())
    assert len(opened) == 1  # the child's inherited list is not read again


def test_scene_check_names_the_unusable_avatar_headless(tmp_path: Path) -> None:
    """The check needs no GL: a fresh interpreter with no display runs it, and imports nothing of render."""
    (tmp_path / "x.glb").write_bytes(b"hello\n")
    scene = _with_avatar(tmp_path, "x.glb")
    code = ("import sys; from pedvr.cli import main; code = main(['scene', 'check', sys.argv[1]]); "
            "bad = [m for m in ('pedvr.render', 'moderngl', 'glfw') if m in sys.modules]; "
            "print('imported', bad); sys.exit(code)")
    r = subprocess.run([sys.executable, "-c", code, str(scene)], capture_output=True, text=True, timeout=300,
                       env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert r.returncode == 2, r.stderr
    lines = r.stdout.splitlines()
    assert lines[-1] == "imported []"
    assert lines[0] == (f"{scene}: agents.profiles.adult.characters[1] = 'x.glb': {tmp_path / 'x.glb'}: not a "
                        "readable glTF 2.0 file: a .glb file is binary glTF and starts with b'glTF'; this one "
                        "starts with b'hello\\n'")


# -- coincident spawns (issue 24.1) ----------------------------------------------------------------


def test_coincident_spawns_are_a_warning_exit_0(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    data = patched(agents__spawns=[
        {"profile": "adult", "state": "walk", "positions": [[-3.0, 0.0], [-3.0, 0.0]]},
        {"profile": "child", "state": "walk", "positions": [[-3.3, 0.0], [2.0, -3.0]]},
    ])
    p = write(tmp_path, data)
    assert main(["scene", "check", str(p)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [
        f"{p}: warning: agents.spawns[0].positions[0] = [-3.0, 0.0]: at the same point as "
        "agents.spawns[0].positions[1]: the two bodies start on top of each other",
        f"{p}: warning: agents.spawns[0].positions[0] = [-3.0, 0.0]: 0.30 m from agents.spawns[1].positions[0], "
        "closer than their radii (0.25 + 0.2 m): the two bodies start overlapping",
        f"{p}: warning: agents.spawns[0].positions[1] = [-3.0, 0.0]: 0.30 m from agents.spawns[1].positions[0], "
        "closer than their radii (0.25 + 0.2 m): the two bodies start overlapping",
        f"{p}: ok: scene 't', 4 agents, 1 obstacle, 2 states; 3 warnings",
    ]


def test_touching_but_apart_and_the_users_start(tmp_path: Path) -> None:
    apart = patched(agents__spawns=[{"profile": "adult", "state": "walk", "positions": [[-3.0, 0.0], [-2.5, 0.0]]}])
    assert spawn_warnings(load_scene(write(tmp_path, apart))) == []  # 0.5 m = 0.25 + 0.25: touching, not in
    on_user = patched(agents__spawns=[{"profile": "adult", "state": "walk", "positions": [[-3.8, -4.0]]}])
    p = write(tmp_path, on_user)
    assert spawn_warnings(load_scene(p)) == [
        f"{p}: warning: agents.spawns[0].positions[0] = [-3.8, -4.0]: 0.20 m from the user's start (user.start), "
        "closer than their radii (0.25 + 0.25 m): the two bodies start overlapping"
    ]
    no_user = patched(agents__spawns=[{"profile": "adult", "state": "walk", "positions": [[-3.8, -4.0]]}],
                      user__enabled=False)
    assert spawn_warnings(load_scene(write(tmp_path, no_user))) == []


@pytest.mark.parametrize("path", shipped_scenes(), ids=lambda p: p.stem)
def test_no_shipped_scene_starts_bodies_overlapping(path: Path) -> None:
    assert spawn_warnings(load_scene(path)) == []


def test_warnings_do_not_hide_problems(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    good = patched(agents__spawns=[{"profile": "adult", "state": "walk", "positions": [[-3.0, 0.0], [-3.0, 0.0]]}])
    bad = tmp_path / "bad"
    bad.mkdir()
    p_bad = write(bad, patched(agents__profiles__adult__radius=-1))
    p_good = write(tmp_path, good)
    assert main(["scene", "check", str(p_good), str(p_bad)]) == 2  # a problem in any file: 2
    out = capsys.readouterr().out
    assert f"{p_good}: warning: " in out and "agents.profiles.adult.radius = -1: must be > 0" in out
