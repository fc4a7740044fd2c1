"""Small skinned glTF humanoids made in the tests (no assets in the repository)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pygltflib
from PIL import Image

# (name, parent, world position) of a T-posed 1.8 m figure, Mixamo's names.
MIXAMO = [
    ("mixamorig:Hips", None, (0.0, 1.0, 0.0)),
    ("mixamorig:Spine", "mixamorig:Hips", (0.0, 1.1, 0.0)),
    ("mixamorig:Spine1", "mixamorig:Spine", (0.0, 1.25, 0.0)),
    ("mixamorig:Spine2", "mixamorig:Spine1", (0.0, 1.4, 0.0)),
    ("mixamorig:Neck", "mixamorig:Spine2", (0.0, 1.55, 0.0)),
    ("mixamorig:Head", "mixamorig:Neck", (0.0, 1.65, 0.0)),
    ("mixamorig:HeadTop_End", "mixamorig:Head", (0.0, 1.8, 0.0)),
]
for side, sx in (("Left", 1.0), ("Right", -1.0)):
    MIXAMO += [
        (f"mixamorig:{side}Shoulder", "mixamorig:Spine2", (0.05 * sx, 1.5, 0.0)),
        (f"mixamorig:{side}Arm", f"mixamorig:{side}Shoulder", (0.2 * sx, 1.5, 0.0)),
        (f"mixamorig:{side}ForeArm", f"mixamorig:{side}Arm", (0.48 * sx, 1.5, 0.0)),
        (f"mixamorig:{side}Hand", f"mixamorig:{side}ForeArm", (0.73 * sx, 1.5, 0.0)),
        (f"mixamorig:{side}HandMiddle1", f"mixamorig:{side}Hand", (0.82 * sx, 1.5, 0.0)),
        (f"mixamorig:{side}UpLeg", "mixamorig:Hips", (0.1 * sx, 0.95, 0.0)),
        (f"mixamorig:{side}Leg", f"mixamorig:{side}UpLeg", (0.1 * sx, 0.52, 0.0)),
        (f"mixamorig:{side}Foot", f"mixamorig:{side}Leg", (0.1 * sx, 0.1, 0.0)),
        (f"mixamorig:{side}ToeBase", f"mixamorig:{side}Foot", (0.1 * sx, 0.02, 0.12)),
    ]


def _box(a: np.ndarray, b: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed box of half-width ``r`` around the segment a-b: 8 corners, 12 outward triangles."""
    lo, hi = np.minimum(a, b) - r, np.maximum(a, b) + r
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    t = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return c, t


def build(path: Path, *, joints: list[tuple[str, str | None, tuple[float, float, float]]] = MIXAMO,
          skinned: bool = True, facing_minus_z: bool = False, vrm: dict[str, str] | None = None,
          colour: tuple[int, int, int] = (30, 160, 60)) -> Path:
    """Write a skinned humanoid of boxes (one per bone, weighted to it) as ``path`` (.glb)."""
    names = [j[0] for j in joints]
    world = np.array([j[2] for j in joints], np.float64)
    if facing_minus_z:
        world = world * np.array([-1.0, 1.0, -1.0])
    parent = [names.index(p) if p else -1 for _, p, _ in joints]
    verts, tris, bones = [], [], []
    for i in range(len(parent)):
        children = [k for k, q in enumerate(parent) if q == i]
        if not children:
            continue
        c, t = _box(world[i], world[children[0]], 0.05 if i else 0.12)
        tris.append(t + sum(len(v) for v in verts))
        verts.append(c)
        bones += [i] * len(c)
    pos = np.concatenate(verts).astype(np.float32)
    idx = np.concatenate(tris).astype(np.uint32)
    n = len(pos)
    nrm = (pos - pos.mean(axis=0)).astype(np.float32)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    uv = np.full((n, 2), 0.5, np.float32)
    jnt = np.zeros((n, 4), np.uint16)
    jnt[:, 0] = bones
    wgt = np.zeros((n, 4), np.float32)
    wgt[:, 0] = 1.0
    ibm = np.zeros((len(names), 4, 4), np.float32)
    for i in range(len(names)):
        m = np.eye(4)
        m[:3, 3] = -world[i]
        ibm[i] = m.T  # column-major
    png = io.BytesIO()
    Image.new("RGBA", (4, 4), (*colour, 255)).save(png, format="PNG")
    chunks = [pos.tobytes(), nrm.tobytes(), uv.tobytes(), jnt.tobytes(), wgt.tobytes(), idx.tobytes(),
              ibm.tobytes(), png.getvalue()]
    blob, views, off = b"", [], 0
    for c in chunks:
        pad = (-len(blob)) % 4
        blob += b"\0" * pad
        off = len(blob)
        views.append(pygltflib.BufferView(buffer=0, byteOffset=off, byteLength=len(c)))
        blob += c
    acc = [
        pygltflib.Accessor(bufferView=0, componentType=5126, count=n, type="VEC3",
                           min=pos.min(axis=0).tolist(), max=pos.max(axis=0).tolist()),
        pygltflib.Accessor(bufferView=1, componentType=5126, count=n, type="VEC3"),
        pygltflib.Accessor(bufferView=2, componentType=5126, count=n, type="VEC2"),
        pygltflib.Accessor(bufferView=3, componentType=5123, count=n, type="VEC4"),
        pygltflib.Accessor(bufferView=4, componentType=5126, count=n, type="VEC4"),
        pygltflib.Accessor(bufferView=5, componentType=5125, count=idx.size, type="SCALAR"),
        pygltflib.Accessor(bufferView=6, componentType=5126, count=len(names), type="MAT4"),
    ]
    nodes = []
    for i, name in enumerate(names):
        local = world[i] - (world[parent[i]] if parent[i] >= 0 else 0.0)
        nodes.append(pygltflib.Node(name=name, translation=local.tolist(),
                                    children=[k for k, q in enumerate(parent) if q == i]))
    mesh_node = len(nodes)
    nodes.append(pygltflib.Node(name="body", mesh=0, skin=0 if skinned else None))
    prim = pygltflib.Primitive(attributes=pygltflib.Attributes(
        POSITION=0, NORMAL=1, TEXCOORD_0=2, JOINTS_0=3 if skinned else None, WEIGHTS_0=4 if skinned else None),
        indices=5, material=0)
    g = pygltflib.GLTF2(
        scene=0, scenes=[pygltflib.Scene(nodes=[0, mesh_node])], nodes=nodes,
        meshes=[pygltflib.Mesh(primitives=[prim])],
        skins=[pygltflib.Skin(joints=list(range(len(names))), inverseBindMatrices=6)] if skinned else [],
        accessors=acc, bufferViews=views, buffers=[pygltflib.Buffer(byteLength=len(blob))],
        images=[pygltflib.Image(bufferView=7, mimeType="image/png")],
        textures=[pygltflib.Texture(source=0)],
        materials=[pygltflib.Material(pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorTexture=pygltflib.TextureInfo(index=0)))],
    )
    if vrm is not None:
        g.extensionsUsed = ["VRMC_vrm"]
        g.extensions = {"VRMC_vrm": {"specVersion": "1.0", "humanoid": {
            "humanBones": {bone: {"node": names.index(node)} for bone, node in vrm.items()}}}}
    g.set_binary_blob(blob)
    g.save_binary(str(path))
    return path
