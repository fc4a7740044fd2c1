"""Bring your own avatars: skinned glTF 2.0 / VRM characters on pedvr's skeleton (no GL).

:func:`load_avatar` reads a ``.glb``/``.gltf``/``.vrm`` file with pygltflib,
takes its skinned mesh (every primitive of the first skinned mesh node),
maps the skin's bones onto the 26 joints (:func:`map_bones`: VRM humanoid
bones first, then names by the common conventions — Mixamo, VRM/Unity
humanoid, Unreal, Blender ``.L``/``.R`` — and a scene's override map), and
retargets the rest pose: each mapped bone is turned, parents first, so that
it points the way pedvr's bind pose points it (arms hanging, legs straight,
identity rotations), the figure faces +Z, stands on the floor and is scaled
to the 1.75 m reference height. Bones that are not mapped (fingers, twist
bones, hair) give their weights to their nearest mapped ancestor.

The result is a :class:`~pedvr.render.bodymesh.CharacterMesh` whose
``rest`` holds the avatar's own bind-pose joints, so the renderer's skinning
matrices turn each vertex about the avatar's joint and carry it to where
the body layer puts that joint (issue 16: drawn instanced like the built-in
character). Its levels of detail are the mesh decimated to 30 % and 10 %,
attributes carried over from the nearest original vertex.

Choices (the issue leaves them open): only the base colour is used (the
first textured material's ``baseColorTexture``, times each primitive's
``baseColorFactor``); morph targets and animations are ignored; VRM 0.x
models (which face −Z) are recognised by their left hip lying at −X and
turned round.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from pedvr.body import JOINTS, PARENTS, REST_OFFSETS
from pedvr.body import skeleton as sk
from pedvr.render.bodymesh import ALWAYS, VERTEX_DTYPE, CharacterMesh, MeshLOD, _decimate, lod_deviation

# The file is read and checked GL-free in the scene layer (scene check and scene loading use the same
# check); these names stay importable from here.
from pedvr.scene.avatars import REQUIRED, AvatarError, map_bones, normalise_bone_name, open_avatar
from pedvr.scene.avatars import accessor as _accessor

__all__ = ["REQUIRED", "AvatarError", "load_avatar", "map_bones", "normalise_bone_name"]

TEXTURED = 12  # crowd.glsl's region for avatars' base-colour texture
AVATAR_DEVIATION_SPACING = 0.003  # m: how finely levels of detail's deviations are measured at load,
AVATAR_DEVIATION_POINTS = 50_000  # at most about this many points a level (a second or two)

_MAIN_CHILD = {"Pelvis": "Spine1", "Spine1": "Spine2", "Spine2": "Spine3", "Spine3": "Neck", "Neck": "Head",
               **{f"{s}{a}": f"{s}{b}" for s in "LR" for a, b in (
                   ("Collar", "Shoulder"), ("Shoulder", "Elbow"), ("Elbow", "Wrist"), ("Wrist", "Hand"),
                   ("Hip", "Knee"), ("Knee", "Ankle"), ("Ankle", "Toe"))}}


def _node_matrix(node: object) -> np.ndarray:
    if node.matrix:  # type: ignore[attr-defined]
        return np.asarray(node.matrix, np.float64).reshape(4, 4).T  # type: ignore[attr-defined]
    m = np.eye(4)
    if node.scale:  # type: ignore[attr-defined]
        m = np.diag(np.r_[np.asarray(node.scale, np.float64), 1.0])  # type: ignore[attr-defined]
    if node.rotation:  # type: ignore[attr-defined]
        from pedvr.render.math3d import quat_to_matrix

        r = np.eye(4)
        r[:3, :3] = quat_to_matrix(*node.rotation)  # type: ignore[attr-defined]
        m = r @ m
    if node.translation:  # type: ignore[attr-defined]
        m[:3, 3] = node.translation  # type: ignore[attr-defined]
    return m


def _world_matrices(gltf: object) -> tuple[list[np.ndarray], list[int]]:
    nodes = gltf.nodes  # type: ignore[attr-defined]
    parent = [-1] * len(nodes)
    for i, n in enumerate(nodes):
        for c in n.children or []:
            parent[c] = i
    world: list[np.ndarray | None] = [None] * len(nodes)

    def get(i: int) -> np.ndarray:
        w = world[i]
        if w is None:
            local = _node_matrix(nodes[i])
            w = local if parent[i] < 0 else get(parent[i]) @ local
            world[i] = w
        return w

    return [get(i) for i in range(len(nodes))], parent


def _image(gltf: object, bufs: list[bytes], path: Path, index: int) -> np.ndarray | None:
    from PIL import Image

    img = gltf.images[index]  # type: ignore[attr-defined]
    try:
        if img.bufferView is not None:
            view = gltf.bufferViews[img.bufferView]  # type: ignore[attr-defined]
            start = view.byteOffset or 0
            data = bufs[view.buffer][start : start + view.byteLength]
            pil = Image.open(io.BytesIO(data))
        elif img.uri and img.uri.startswith("data:"):
            import base64

            pil = Image.open(io.BytesIO(base64.b64decode(img.uri.split(",", 1)[1])))
        elif img.uri:
            pil = Image.open(path.parent / img.uri)
        else:
            return None
        return np.asarray(pil.convert("RGBA"), np.uint8)
    except (OSError, ValueError) as exc:
        raise AvatarError(f"{path}: image {index}: {exc}") from None


# -- retargeting ----------------------------------------------------------------------------------


def _align(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking direction ``a`` onto direction ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if c < -0.999999:
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def load_avatar(path: str | Path, *, bone_map: dict[str, str] | None = None) -> CharacterMesh:
    """A skinned glTF/VRM file as a character on pedvr's skeleton; :class:`AvatarError` if unusable
    (:func:`pedvr.scene.avatars.open_avatar` checks the file, as the scene loader does)."""
    f = open_avatar(path, bone_map=bone_map)
    path, gltf, bufs, node, skin, mapping = f.path, f.gltf, f.buffers, f.node, f.skin, f.mapping
    names = f.names
    world, _ = _world_matrices(gltf)
    if skin.inverseBindMatrices is not None:
        ibm = _accessor(gltf, bufs, skin.inverseBindMatrices).astype(np.float64).reshape(-1, 4, 4)
        bind = np.linalg.inv(ibm.transpose(0, 2, 1))  # column-major in the file
    else:
        bind = np.stack([world[j] for j in skin.joints])

    # Gather every primitive of the skinned mesh.
    pos, nrm, uv, jnt, wgt, tri, colour = [], [], [], [], [], [], []
    texture: np.ndarray | None = None
    base = 0
    for prim in gltf.meshes[node.mesh].primitives:
        a = prim.attributes  # open_avatar checked each attribute, the mode and the indices
        p = _accessor(gltf, bufs, a.POSITION).astype(np.float64)
        n = len(p)
        idx = (_accessor(gltf, bufs, prim.indices).ravel().astype(np.int64) if prim.indices is not None
               else np.arange(n))
        pos.append(p)
        nrm.append(_accessor(gltf, bufs, a.NORMAL).astype(np.float64) if a.NORMAL is not None else None)
        uv.append(_accessor(gltf, bufs, a.TEXCOORD_0).astype(np.float64) if a.TEXCOORD_0 is not None
                  else np.zeros((n, 2)))
        jnt.append(_accessor(gltf, bufs, a.JOINTS_0).astype(np.int64))
        wgt.append(_accessor(gltf, bufs, a.WEIGHTS_0).astype(np.float64))
        tri.append(idx.reshape(-1, 3) + base)
        factor = np.ones(4)
        if prim.material is not None:
            pbr = gltf.materials[prim.material].pbrMetallicRoughness
            if pbr is not None and pbr.baseColorFactor:
                factor = np.asarray(pbr.baseColorFactor, np.float64)
            if pbr is not None and pbr.baseColorTexture is not None and texture is None:
                src = gltf.textures[pbr.baseColorTexture.index].source
                texture = _image(gltf, bufs, path, src) if src is not None else None
        colour.append(np.tile(factor[:3], (n, 1)))
        base += n
    v = np.concatenate(pos)
    t = np.concatenate(tri)
    normals = _vertex_normals(v, t) if any(x is None for x in nrm) else np.concatenate(nrm)  # type: ignore[arg-type]
    uvs, joints, weights, cols = (np.concatenate(x) for x in (uv, jnt, wgt, colour))

    # Avatar bones -> pedvr joints: mapped ones directly, the rest through their mapped ancestors.
    joint_of = np.full(len(names), _J_INDEX["Pelvis"], np.int64)
    node_parent = {c: i for i, nd in enumerate(gltf.nodes) for c in (nd.children or [])}
    by_node = {skin.joints[i]: JOINTS.index(jn) for jn, i in mapping.items()}
    for k, nidx in enumerate(skin.joints):
        cur: int | None = nidx
        while cur is not None and cur not in by_node:
            cur = node_parent.get(cur)
        if cur is not None:
            joint_of[k] = by_node[cur]

    # Bind-pose joint positions; joints the avatar lacks are placed from pedvr's rest offsets.
    ref = _rest_reference()
    pa = np.zeros((len(JOINTS), 3))
    have = np.zeros(len(JOINTS), bool)
    for joint, i in mapping.items():
        pa[JOINTS.index(joint)] = bind[i][:3, 3]
        have[JOINTS.index(joint)] = True
    head, pelvis = _J_INDEX["Head"], _J_INDEX["Pelvis"]
    span = np.linalg.norm(pa[head] - pa[pelvis]) / np.linalg.norm(ref[head] - ref[pelvis])
    # Facing: the left hip must lie at +X when the figure faces +Z (VRM 0.x faces -Z).
    turn = np.eye(3)
    if pa[_J_INDEX["LHip"], 0] < pa[_J_INDEX["RHip"], 0]:
        turn = np.diag([-1.0, 1.0, -1.0])
    pa = pa @ turn.T
    v = v @ turn.T
    normals = normals @ turn.T
    for j in range(len(JOINTS)):
        if not have[j]:
            pa[j] = pa[PARENTS[j]] + REST_OFFSETS[j] * span
    # Retarget: turn each joint's bone onto pedvr's rest direction, parents first.
    rot = np.tile(np.eye(3), (len(JOINTS), 1, 1))
    new = np.zeros_like(pa)
    for j, name in enumerate(JOINTS):
        par = int(PARENTS[j])
        if par >= 0:
            new[j] = new[par] + rot[par] @ (pa[j] - pa[par])
            rot[j] = rot[par]
        else:
            new[j] = pa[j]
        child = _MAIN_CHILD.get(name)
        if child is not None and j != _J_INDEX["Pelvis"]:
            c = _J_INDEX[child]
            d_avatar = rot[j] @ (pa[c] - pa[j])
            d_pedvr = ref[c] - ref[j]
            if np.linalg.norm(d_avatar) > 1e-6:
                rot[j] = _align(d_avatar, d_pedvr) @ rot[j]
    jj = joint_of[joints]  # (V, 4) pedvr joints
    w = weights / np.maximum(weights.sum(axis=1, keepdims=True), 1e-12)
    vp = np.zeros_like(v)
    vn = np.zeros_like(normals)
    for k in range(4):
        r = rot[jj[:, k]]
        vp += w[:, k, None] * (new[jj[:, k]] + np.einsum("vij,vj->vi", r, v - pa[jj[:, k]]))
        vn += w[:, k, None] * np.einsum("vij,vj->vi", r, normals)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-12)
    # On the floor, centred on the pelvis, 1.75 m tall.
    height = float(vp[:, 1].max() - vp[:, 1].min())
    if height <= 1e-6:
        raise AvatarError(f"{path}: the skinned mesh has no height")
    s = sk.REFERENCE_HEIGHT / height
    origin = np.array([new[0, 0], vp[:, 1].min(), new[0, 2]])
    vp = (vp - origin) * s
    rest = ((new - origin) * s).astype(np.float32)

    # Per vertex: up to four pedvr joints, merged and normalised.
    full = np.zeros((len(v), len(JOINTS)))
    for k in range(4):
        np.add.at(full, (np.arange(len(v)), jj[:, k]), w[:, k])
    out = np.zeros(len(v), VERTEX_DTYPE)
    out["pos"], out["normal"], out["uv"] = vp, vn, uvs
    order = np.argsort(-full, axis=1, kind="stable")[:, :4]
    top = np.take_along_axis(full, order, axis=1)
    top = np.where(top > 1e-4, top, 0.0)
    top /= np.maximum(top.sum(axis=1, keepdims=True), 1e-12)
    out["bones"], out["weights"] = np.where(top > 0, order, 0), top
    out["region"], out["variant"], out["ao"] = TEXTURED, ALWAYS, 1.0
    out["local"] = cols  # the primitive's base colour factor (crowd.glsl multiplies the texture by it)
    lod0 = MeshLOD(vertices=out, triangles=t.astype(np.uint32))
    lods = [lod0] + [_reduced(lod0, frac) for frac in (0.3, 0.1)]
    return CharacterMesh(name=path.stem, lods=tuple(lods), rest=rest, texture=texture,
                         lod_error=lod_deviation(lods, spacing=AVATAR_DEVIATION_SPACING,
                                                 max_points=AVATAR_DEVIATION_POINTS))


_J_INDEX = {n: i for i, n in enumerate(JOINTS)}


def _rest_reference() -> np.ndarray:
    from pedvr.body import rest_positions

    return rest_positions(sk.user_dims(1))[0, : len(JOINTS)]


def _vertex_normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, t[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def _reduced(lod: MeshLOD, fraction: float) -> MeshLOD:
    """The mesh decimated to ``fraction`` of its triangles, each new vertex taking the attributes of
    the nearest original one (UV seams may smear a little at these distances)."""
    from scipy.spatial import cKDTree

    t = lod.triangles.astype(np.int64)
    target = max(12, int(len(t) * fraction))
    if target >= len(t):
        return lod
    v, tri = _decimate(lod.vertices["pos"].astype(np.float64), t, target, closed=False)
    _, near = cKDTree(lod.vertices["pos"]).query(v)
    out = lod.vertices[near].copy()
    out["pos"] = v
    return MeshLOD(vertices=out, triangles=tri.astype(np.uint32))
