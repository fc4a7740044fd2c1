"""Bring your own avatars (issue 16): skinned glTF/VRM files the tests build themselves."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import moderngl
import numpy as np
import pytest

from pedvr.body import JOINTS
from pedvr.body import skeleton as sk
from pedvr.render.avatars import AvatarError, load_avatar, map_bones, normalise_bone_name
from pedvr.render.bodymesh import procedural_character
from pedvr.render.crowd import skin_rows
from pedvr.render.math3d import first_person_eye
from pedvr.render.renderer import OffscreenTarget, Renderer
from tests.render.conftest import EMPTY, posed
from tests.render.gltf_builder import MIXAMO, build

J = {n: i for i, n in enumerate(JOINTS)}


@pytest.mark.parametrize("name,expect", [
    ("mixamorig:LeftArm", "leftarm"), ("J_Bip_L_UpperArm", "leftupperarm"), ("upperarm_l", "leftupperarm"),
    ("UpperArm.R", "rightupperarm"), ("RightUpLeg", "rightupleg"), ("Hips", "hips"),
])
def test_bone_names_normalise_across_conventions(name: str, expect: str) -> None:
    assert normalise_bone_name(name) == expect


def test_mixamo_unity_and_vrm_names_map_to_the_same_joints() -> None:
    mixamo = map_bones(["mixamorig:Hips", "mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:LeftHand",
                        "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2"])
    unity = map_bones(["Hips", "LeftUpperArm", "LeftLowerArm", "LeftHand", "Spine", "Chest", "UpperChest"])
    assert mixamo == unity == {"Pelvis": 0, "LShoulder": 1, "LElbow": 2, "LWrist": 3, "Spine1": 4,
                               "Spine2": 5, "Spine3": 6}
    assert map_bones(["b0", "b1"], vrm={"hips": 0, "leftUpperArm": 1}) == {"Pelvis": 0, "LShoulder": 1}
    assert map_bones(["Bacino"], overrides={"Bacino": "Pelvis"}) == {"Pelvis": 0}


def test_a_t_posed_avatar_is_retargeted_to_the_bind_pose(tmp_path: Path) -> None:
    ch = load_avatar(build(tmp_path / "a.glb"))
    rest = ch.rest
    assert rest is not None and rest.shape == (26, 3)
    # Arms hang (T-pose arms were horizontal), shoulders stay apart, the figure stands on the floor.
    for s, sgn in (("L", 1.0), ("R", -1.0)):
        sh, wr = rest[J[f"{s}Shoulder"]], rest[J[f"{s}Wrist"]]
        assert sh[1] - wr[1] > 0.4 and abs(wr[0] - sh[0]) < 0.02 and sgn * sh[0] > 0.1
    v = ch.lods[0].vertices
    assert v["pos"][:, 1].min() == pytest.approx(0.0, abs=1e-6)
    assert v["pos"][:, 1].max() == pytest.approx(sk.REFERENCE_HEIGHT, abs=1e-4)
    assert np.allclose(v["weights"].sum(axis=1), 1.0, atol=1e-5)
    # Fingers (unmapped HandMiddle1's children do not exist; HandMiddle1 maps to LHand).
    assert set(np.unique(v["bones"][:, 0])) <= set(range(26))


def test_a_vrm_facing_minus_z_is_turned_round_and_mapped_by_its_humanoid_table(tmp_path: Path) -> None:
    names = {"hips": "mixamorig:Hips", "spine": "mixamorig:Spine", "chest": "mixamorig:Spine1",
             "upperChest": "mixamorig:Spine2", "neck": "mixamorig:Neck", "head": "mixamorig:Head"}
    for side, s in (("left", "Left"), ("right", "Right")):
        names |= {f"{side}UpperArm": f"mixamorig:{s}Arm", f"{side}LowerArm": f"mixamorig:{s}ForeArm",
                  f"{side}Hand": f"mixamorig:{s}Hand", f"{side}UpperLeg": f"mixamorig:{s}UpLeg",
                  f"{side}LowerLeg": f"mixamorig:{s}Leg", f"{side}Foot": f"mixamorig:{s}Foot"}
    odd = [(f"bone{k}", None if p is None else f"bone{[j[0] for j in MIXAMO].index(p)}", w)
           for k, (_, p, w) in enumerate(MIXAMO)]
    renamed = {bone: f"bone{[j[0] for j in MIXAMO].index(n)}" for bone, n in names.items()}
    ch = load_avatar(build(tmp_path / "v.vrm", joints=odd, facing_minus_z=True, vrm=renamed))
    assert ch.rest is not None and ch.rest[J["LHip"], 0] > 0.05  # the left hip on the left (+X)
    assert ch.rest[J["LToe"], 2] > ch.rest[J["LAnkle"], 2]  # toes ahead: facing +Z


def test_the_skinned_avatar_follows_the_body(tmp_path: Path) -> None:
    ch = load_avatar(build(tmp_path / "a.glb"))
    snap, body = posed([[1.0, 0.5]], [0.3], vel=[[1.2 * math.cos(0.3), 1.2 * math.sin(0.3)]], seconds=1.0,
                       reference=True)
    assert snap.bones is not None and ch.rest is not None
    out = np.zeros((1, 78, 4), np.float32)
    skin_rows(snap.bones, np.zeros(1, np.int64), np.ones(1, np.float32), ch.rest[None], out)
    m = out[0].reshape(26, 3, 4).astype(np.float64)
    v = ch.lods[0].vertices
    hp = np.c_[v["pos"], np.ones(len(v))]
    world = sum(v["weights"][:, k, None] * np.einsum("vij,vj->vi", m[v["bones"][:, k]], hp) for k in range(4))
    # Each avatar joint lands where the body puts the joint (the matrices carry rest onto the pose).
    for j in (J["LWrist"], J["RAnkle"], J["Head"]):
        moved = m[j] @ np.r_[ch.rest[j], 1.0]
        assert np.linalg.norm(moved - body.state.world_pos[0, j]) < 1e-4
    hand = world[(v["bones"][:, 0] == J["LWrist"]) & (v["weights"][:, 0] > 0.99)]
    assert np.linalg.norm(hand.mean(axis=0) - body.state.world_pos[0, J["LWrist"]]) < 0.12


def test_avatars_are_drawn_instanced_beside_the_procedural_crowd(ctx: moderngl.Context, tmp_path: Path) -> None:
    ch = load_avatar(build(tmp_path / "g.glb", colour=(20, 200, 40)))
    r = Renderer(ctx, world=EMPTY, characters=[procedural_character(), ch])
    try:
        snap, _ = posed([[2.5, -0.5], [2.5, 0.5]], [math.pi, math.pi], reference=True)
        snap = dataclasses.replace(snap, character=np.array([1, 1]))
        eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.2, aspect=96 / 64)
        t = OffscreenTarget(ctx, (96, 64))
        r.begin_frame()
        r.update(snap)
        r.draw_scene([eye], framebuffer=t.fbo)
        img = t.read().astype(int)
        t.release()
        green = (img[:, :, 1] > 110) & (img[:, :, 0] < 90) & (img[:, :, 2] < 90)
        assert green.sum() > 60  # the avatar's texture colour, on both figures
        assert green[:, :48].sum() > 30 and green[:, 48:].sum() > 30
        # One draw for both avatars in the view, one in the shadow map, plus the world's.
        assert r.stats.draw_calls == 2 + 1 + 1 + 1 + 1
        with pytest.raises(ValueError, match="character index 2: this renderer has 2 characters"):
            r.update(dataclasses.replace(snap, character=np.array([2, 0])))
    finally:
        r.release()


def test_unusable_files_say_which_and_what_is_missing(tmp_path: Path) -> None:
    with pytest.raises(AvatarError, match=r"n\.glb: no skin"):
        load_avatar(build(tmp_path / "n.glb", skinned=False))
    odd = [(n.replace("Arm", "Wing"), p.replace("Arm", "Wing") if p else None, w) for n, p, w in MIXAMO]
    path = build(tmp_path / "w.glb", joints=odd)
    with pytest.raises(AvatarError, match=r"w\.glb: bones not mapped to pedvr's skeleton: "
                                          r"LShoulder, LElbow, RShoulder, RElbow \(skin bones: mixamorig:Hips"):
        load_avatar(path)
    fixed = load_avatar(path, bone_map={"mixamorig:LeftWing": "LShoulder", "mixamorig:RightWing": "RShoulder",
                                        "mixamorig:LeftForeWing": "LElbow", "mixamorig:RightForeWing": "RElbow"})
    assert fixed.rest is not None
    (tmp_path / "junk.glb").write_bytes(b"not gltf")
    with pytest.raises(AvatarError, match=r"junk\.glb: not a readable glTF 2\.0 file"):
        load_avatar(tmp_path / "junk.glb")
