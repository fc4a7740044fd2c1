"""Scene and profile keys choose characters per profile (issue 16)."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest
import tomli_w

from pedvr.errors import SceneError
from pedvr.render.renderer import Renderer
from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_scene
from pedvr.sim import Simulation
from tests.render.gltf_builder import MIXAMO, build
from tests.scene.test_loader import GOOD, patched


def _scene(tmp_path: Path, chars: object, **extra: object) -> Path:
    d = patched(agents__profiles__adult__characters=chars, **extra)
    d["agents"]["spawns"] = [{"profile": "adult", "state": "walk", "positions": [[-3.0, 0.0], [-3.0, 1.0],
                                                                                 [-2.0, 0.5], [-1.0, -1.0]]},
                             {"profile": "child", "state": "walk", "positions": [[-3.0, -2.0]]}]
    p = tmp_path / "s.toml"
    p.write_bytes(tomli_w.dumps(d).encode())
    return p


def test_profiles_pick_their_characters_per_agent(ctx: moderngl.Context, tmp_path: Path) -> None:
    (tmp_path / "avatars").mkdir()
    build(tmp_path / "avatars" / "a.glb")
    build(tmp_path / "avatars" / "b.glb", colour=(200, 40, 40))
    scene = load_scene(_scene(tmp_path, ["builtin", "avatars/*.glb"]))
    adult, child = scene.profiles["adult"], scene.profiles["child"]
    assert adult.characters == ("builtin", str((tmp_path / "avatars/a.glb").resolve()),
                                str((tmp_path / "avatars/b.glb").resolve()))
    assert child.characters == adult.characters  # inherited, like every profile key
    sim = Simulation(scene)
    sim.step()
    snap = Snapshot.from_sim(sim)
    r = Renderer.for_scene(ctx, scene)
    try:
        assert len(r.characters) == 3
        r.update(snap)
        chars = r._drawn_char
        drawn = snap.profile[~snap.is_user]  # type: ignore[index]
        assert set(chars[drawn >= 0]) <= {0, 1, 2} and len(set(chars)) >= 2
        r.update(snap)
        assert np.array_equal(r._drawn_char, chars)  # stable per id
    finally:
        r.release()


def test_missing_files_and_bad_maps_are_reported(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"agents\.profiles\.adult\.characters\[0\] = 'nowhere/\*\.glb': "
                                         r"matches no file in"):
        load_scene(_scene(tmp_path, ["nowhere/*.glb"]))
    (tmp_path / "x.png").write_bytes(b"")
    with pytest.raises(SceneError, match=r"characters\[0\] = 'x.png': x.png: expected a .glb, .gltf, .vrm file"):
        load_scene(_scene(tmp_path, ["x.png"]))
    with pytest.raises(SceneError, match=r"characters.bone_map = 3: expected a table"):
        load_scene(_scene(tmp_path, ["builtin"], characters={"bone_map": 3}))


def test_a_scene_bone_map_fixes_odd_names_and_unknown_joints_are_named(ctx: moderngl.Context,
                                                                       tmp_path: Path) -> None:
    odd = [(n.replace("Arm", "Wing"), p.replace("Arm", "Wing") if p else None, w) for n, p, w in MIXAMO]
    build(tmp_path / "w.glb", joints=odd)
    # Refused when the scene loads (issue 25.11), not when the first frame is drawn.
    with pytest.raises(SceneError, match=r"characters\[0\] = 'w\.glb': \S*w\.glb: bones not mapped to "
                                         r"pedvr's skeleton: LShoulder"):
        load_scene(_scene(tmp_path, ["w.glb"]))
    fixes = {"mixamorig:LeftWing": "LShoulder", "mixamorig:RightWing": "RShoulder",
             "mixamorig:LeftForeWing": "LElbow", "mixamorig:RightForeWing": "RElbow"}
    fixed = load_scene(_scene(tmp_path, ["w.glb"], characters={"bone_map": fixes}))
    Renderer.for_scene(ctx, fixed).release()
    with pytest.raises(SceneError, match=r"w\.glb: bone_map names 'Pelvix': not pedvr joints"):
        load_scene(_scene(tmp_path, ["w.glb"], characters={"bone_map": {"x": "Pelvix"}}))


def test_good_scene_has_no_characters_key() -> None:
    assert "characters" not in GOOD["agents"]["profiles"]["adult"]
