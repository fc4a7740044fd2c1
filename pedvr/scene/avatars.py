"""Avatar files (``characters = ["x.glb"]``) read and checked without GL (issue 25.11).

:func:`open_avatar` reads a ``.glb``/``.gltf``/``.vrm`` file with pygltflib
and checks everything the renderer's :func:`pedvr.render.avatars.load_avatar`
relies on, so that an unusable file is refused when the scene loads (``pedvr
scene check``, a headless run, a sweep) with one line naming the file and what
is wrong, not when the first frame is drawn:

- the container: not empty; a binary file starts with ``glTF``, is version 2,
  and is as long as its header says (a truncated download is caught here);
  a ``.gltf`` is JSON; a ``.glb``/``.vrm`` that is neither is "not binary glTF";
- every buffer holds the bytes it declares (the binary chunk, a data URI, or
  a file beside the model);
- a mesh node with a skin; the skin's joints are nodes; each of its mesh's
  primitives has ``POSITION``, ``JOINTS_0`` and ``WEIGHTS_0``, is made of
  triangles, and every accessor it and the skin use lies inside its buffer
  view and buffer; joint indices name bones of the skin and triangle indices
  name vertices;
- the skin's bones map onto pedvr's skeleton (:func:`map_bones`, with the
  scene's ``[characters] bone_map``), and the bone map names pedvr joints.

The bone-name tables live here because mapping is part of deciding whether a
file is usable; ``pedvr.render.avatars`` imports them (render may import
scene, never the other way round: DESIGN.md). The joint names come from
:mod:`pedvr.body.skeleton`, a data-only module.
"""

from __future__ import annotations

import base64
import json
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pedvr.errors import PedvrError

AVATAR_SUFFIXES = (".glb", ".gltf", ".vrm")

REQUIRED = ("Pelvis", "Head", "LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist",
            "LHip", "LKnee", "LAnkle", "RHip", "RKnee", "RAnkle")

# Normalised bone names (lower case, no separators, side as a "left"/"right" prefix) per joint.
_ALIASES: dict[str, tuple[str, ...]] = {
    "Pelvis": ("hips", "pelvis", "hip"),
    "Spine1": ("spine", "spine01", "spine0"),
    "Spine2": ("chest", "spine1", "spine02"),
    "Spine3": ("upperchest", "spine2", "spine03"),
    "Neck": ("neck", "neck01", "neck1"),
    "Head": ("head",),
    "{s}Eye": ("{s}eye",),
    "{s}Collar": ("{s}shoulder", "{s}clavicle", "{s}collar"),
    "{s}Shoulder": ("{s}upperarm", "{s}arm"),
    "{s}Elbow": ("{s}lowerarm", "{s}forearm"),
    "{s}Wrist": ("{s}hand", "{s}wrist"),
    "{s}Hand": ("{s}middleproximal", "{s}handmiddle1", "{s}middle01", "{s}middle1"),
    "{s}Hip": ("{s}upperleg", "{s}upleg", "{s}thigh"),
    "{s}Knee": ("{s}lowerleg", "{s}leg", "{s}calf", "{s}shin"),
    "{s}Ankle": ("{s}foot", "{s}ankle"),
    "{s}Toe": ("{s}toes", "{s}toebase", "{s}toe", "{s}ball"),
}
_VRM_BONES = {  # VRM humanoid bone -> joint
    "hips": "Pelvis", "spine": "Spine1", "chest": "Spine2", "upperChest": "Spine3", "neck": "Neck",
    "head": "Head", "leftEye": "LEye", "rightEye": "REye",
    **{f"{side}{part}": f"{s}{joint}" for side, s in (("left", "L"), ("right", "R")) for part, joint in (
        ("Shoulder", "Collar"), ("UpperArm", "Shoulder"), ("LowerArm", "Elbow"), ("Hand", "Wrist"),
        ("MiddleProximal", "Hand"), ("UpperLeg", "Hip"), ("LowerLeg", "Knee"), ("Foot", "Ankle"),
        ("Toes", "Toe"))},
}
_IGNORED_TOKENS = {"", "mixamorig", "mixamorig1", "mixamorig2", "j", "bip", "bip01", "c", "def", "armature",
                   "jnt", "joint", "bone", "ctrl", "b"}

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
             5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_GLB_JSON, _GLB_BIN = 0x4E4F534A, 0x004E4942  # chunk types "JSON" and "BIN\0"


class AvatarError(PedvrError):
    """An avatar file cannot be used: one line naming the file and what is wrong."""

    exit_code = 2


def _joints() -> tuple[str, ...]:
    from pedvr.body.skeleton import JOINTS

    return tuple(JOINTS)


def _alias_table() -> dict[str, str]:
    out: dict[str, str] = {}
    for joint, names in _ALIASES.items():
        for s, side in (("L", "left"), ("R", "right")) if "{s}" in joint else (("", ""),):
            for n in names:
                out.setdefault(n.format(s=side), joint.format(s=s))
    return out


_ALIAS = _alias_table()


def normalise_bone_name(name: str) -> str:
    """``mixamorig:LeftArm``, ``J_Bip_L_UpperArm``, ``upperarm_l``, ``UpperArm.L`` → ``leftarm`` /
    ``leftupperarm``: lower case, prefixes dropped, the side as a ``left``/``right`` prefix."""
    tokens = re.split(r"[:_.\s|\-]+", name.strip().lower())
    side = ""
    rest = []
    for tok in tokens:
        if tok in ("l", "left"):
            side = "left"
        elif tok in ("r", "right"):
            side = "right"
        elif tok not in _IGNORED_TOKENS:
            rest.append(tok)
    base = "".join(rest)
    if not side:
        for word in ("left", "right"):
            if base.startswith(word):
                side, base = word, base[len(word):]
            elif base.endswith(word):
                side, base = word, base[: -len(word)]
    return side + base


def map_bones(names: list[str], *, vrm: dict[str, int] | None = None,
              overrides: dict[str, str] | None = None) -> dict[str, int]:
    """pedvr joint → index into ``names`` for the bones that can be mapped.

    Priority: ``overrides`` (bone name → joint, a scene's map), then the VRM
    humanoid table ``vrm`` (VRM bone → index), then the naming conventions.
    """
    joints = _joints()
    out: dict[str, int] = {}
    for i, n in enumerate(names):
        j = (overrides or {}).get(n)
        if j is not None and j in joints:
            out[j] = i
    for bone, i in (vrm or {}).items():
        j = _VRM_BONES.get(bone)
        if j is not None and j not in out and 0 <= i < len(names):
            out[j] = i
    for i, n in enumerate(names):
        j = _ALIAS.get(normalise_bone_name(n))
        if j is not None and j not in out and i not in out.values():
            out[j] = i
    return out


def vrm_humanoid(gltf: Any) -> dict[str, int]:
    """VRM humanoid bone → node index (VRM 1.0 ``VRMC_vrm`` or VRM 0.x ``VRM``), or {}."""
    ext = gltf.extensions or {}
    try:
        if "VRMC_vrm" in ext:  # VRM 1.0
            bones = ext["VRMC_vrm"].get("humanoid", {}).get("humanBones", {})
            return {k: int(v["node"]) for k, v in bones.items() if "node" in v}
        if "VRM" in ext:  # VRM 0.x
            bones = ext["VRM"].get("humanoid", {}).get("humanBones", [])
            return {b["bone"]: int(b["node"]) for b in bones if "bone" in b and "node" in b}
    except (AttributeError, TypeError, ValueError):
        return {}
    return {}


def accessor(gltf: Any, bufs: list[bytes], index: int) -> np.ndarray:
    """The accessor's elements as an ``(count, width)`` array (normalised integers as floats in
    [0, 1]); only for accessors :func:`open_avatar` checked."""
    acc = gltf.accessors[index]
    dtype = np.dtype(COMPONENT[acc.componentType])
    width = WIDTH[acc.type]
    out = np.zeros((acc.count, width), dtype)
    if acc.bufferView is not None:
        view = gltf.bufferViews[acc.bufferView]
        data = bufs[view.buffer]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        stride = view.byteStride or dtype.itemsize * width
        if stride == dtype.itemsize * width:
            out = np.frombuffer(data, dtype, acc.count * width, start).reshape(acc.count, width).copy()
        else:
            for i in range(acc.count):
                out[i] = np.frombuffer(data, dtype, width, start + i * stride)
    if acc.normalized and dtype.kind in "iu":
        out = out.astype(np.float32) / float(np.iinfo(dtype.type).max)  # type: ignore[type-var]
    return out


@dataclass(frozen=True)
class AvatarFile:
    """A checked avatar file: the parsed glTF, its buffers' bytes, the first skinned mesh node
    and its skin, the skin's bone names and their mapping onto pedvr's joints."""

    path: Path
    gltf: Any  # pygltflib.GLTF2
    buffers: list[bytes]
    node: Any  # pygltflib.Node: the first node with a mesh and a skin
    skin: Any  # pygltflib.Skin
    names: list[str]  # the skin's bone names, in skin order
    mapping: dict[str, int]  # pedvr joint -> index into names


def open_avatar(path: str | Path, *, bone_map: dict[str, str] | None = None) -> AvatarFile:
    """Read and check an avatar file (see the module docstring); :class:`AvatarError` if unusable."""
    import pygltflib

    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise AvatarError(f"{path}: cannot read: {exc.strerror}") from None
    unreadable = f"{path}: not a readable glTF 2.0 file"
    if not raw:
        raise AvatarError(f"{unreadable}: it is empty (0 bytes)")
    if raw[:4] == b"glTF":  # .glb and .vrm are binary glTF whatever their suffix
        bin_chunk = _check_glb(raw, unreadable)
        loader = "load_binary"
    else:
        if path.suffix.lower() in (".glb", ".vrm"):
            raise AvatarError(f"{unreadable}: a {path.suffix.lower()} file is binary glTF and starts with "
                              f"b'glTF'; this one starts with {raw[:8]!r}")
        try:
            json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AvatarError(f"{unreadable}: not glTF JSON ({exc})") from None
        bin_chunk = None
        loader = "load_json"
    try:
        gltf = getattr(pygltflib.GLTF2(), loader)(str(path))
    except Exception as exc:  # pygltflib raises whatever its parser hit
        raise AvatarError(f"{unreadable} ({type(exc).__name__}: {exc})") from None
    if gltf is None:
        raise AvatarError(unreadable)
    version = str(getattr(gltf.asset, "version", "") or "")
    if not version.startswith("2."):
        raise AvatarError(f"{unreadable}: its asset.version is {version or 'missing'!r}")
    joints = _joints()
    unknown = sorted(j for j in (bone_map or {}).values() if j not in joints)
    if unknown:
        raise AvatarError(f"{path}: bone_map names {', '.join(repr(j) for j in unknown)}: not pedvr joints; "
                          f"known: {', '.join(joints)}")
    bufs = _buffers(gltf, path, bin_chunk)
    nodes = gltf.nodes or []
    skinned = [n for n in nodes if n.skin is not None and n.mesh is not None]
    if not skinned:
        raise AvatarError(f"{path}: no skin (pedvr needs a mesh skinned to a humanoid skeleton)")
    node = skinned[0]
    if not 0 <= node.skin < len(gltf.skins or []) or not 0 <= node.mesh < len(gltf.meshes or []):
        raise AvatarError(f"{path}: the skinned node names skin {node.skin} and mesh {node.mesh}; the file "
                          f"has {len(gltf.skins or [])} skins and {len(gltf.meshes or [])} meshes")
    skin = gltf.skins[node.skin]
    if not skin.joints or any(not 0 <= j < len(nodes) for j in skin.joints):
        raise AvatarError(f"{path}: skin {node.skin}'s joints are not nodes of the file")
    if skin.inverseBindMatrices is not None:
        _check_accessor(gltf, bufs, path, skin.inverseBindMatrices, f"skin {node.skin}'s inverseBindMatrices",
                        types=("MAT4",), count=len(skin.joints))
    for k, prim in enumerate(gltf.meshes[node.mesh].primitives or []):
        _check_primitive(gltf, bufs, path, prim, f"primitive {k} of mesh {node.mesh}", len(skin.joints))
    if not gltf.meshes[node.mesh].primitives:
        raise AvatarError(f"{path}: mesh {node.mesh} has no primitives")
    names = [nodes[j].name or f"node{j}" for j in skin.joints]
    vrm = {b: skin.joints.index(n) for b, n in vrm_humanoid(gltf).items() if n in skin.joints}
    mapping = map_bones(names, vrm=vrm, overrides=bone_map)
    missing = [j for j in REQUIRED if j not in mapping]
    if missing:
        raise AvatarError(f"{path}: bones not mapped to pedvr's skeleton: {', '.join(missing)} "
                          f"(skin bones: {', '.join(names[:12])}{', ...' if len(names) > 12 else ''}); "
                          "rename them or give a bone_map")
    return AvatarFile(path=path, gltf=gltf, buffers=bufs, node=node, skin=skin, names=names, mapping=mapping)


def _check_glb(raw: bytes, unreadable: str) -> bytes | None:
    """The GLB container (glTF 2.0 §4.4): header, JSON chunk, optional BIN chunk; the BIN bytes."""
    if len(raw) < 20:
        raise AvatarError(f"{unreadable}: truncated ({len(raw)} bytes; a binary glTF header alone is 20)")
    _, version, length = struct.unpack_from("<4sII", raw, 0)
    if version != 2:
        raise AvatarError(f"{unreadable}: binary glTF version {version}; pedvr reads version 2")
    if length != len(raw):
        what = "truncated" if len(raw) < length else "longer than its header says"
        raise AvatarError(f"{unreadable}: {what} ({len(raw)} bytes; its header declares {length})")
    json_len, json_type = struct.unpack_from("<II", raw, 12)
    if json_type != _GLB_JSON or 20 + json_len > len(raw):
        raise AvatarError(f"{unreadable}: its first chunk is not a whole JSON chunk")
    at = 20 + json_len
    if at + 8 > len(raw):
        return None
    bin_len, bin_type = struct.unpack_from("<II", raw, at)
    if bin_type != _GLB_BIN:
        return None
    if at + 8 + bin_len > len(raw):
        raise AvatarError(f"{unreadable}: its binary chunk declares {bin_len} bytes; "
                          f"the file holds {len(raw) - at - 8}")
    return raw[at + 8 : at + 8 + bin_len]


def _buffers(gltf: Any, path: Path, bin_chunk: bytes | None) -> list[bytes]:
    out = []
    for k, buf in enumerate(gltf.buffers or []):
        uri = buf.uri
        if uri is None:
            if bin_chunk is None:
                raise AvatarError(f"{path}: buffer {k} has no data (no binary chunk and no uri)")
            data = bin_chunk
        elif uri.startswith("data:"):
            try:
                data = base64.b64decode(uri.split(",", 1)[1], validate=True)
            except (IndexError, ValueError):
                raise AvatarError(f"{path}: buffer {k}: its data URI is not base64") from None
        else:
            try:
                data = (path.parent / uri).read_bytes()
            except OSError as exc:
                raise AvatarError(f"{path}: buffer {k} {uri!r}: {exc.strerror}") from None
        declared = buf.byteLength or 0
        if len(data) < declared:
            raise AvatarError(f"{path}: buffer {k} holds {len(data)} bytes; the file declares {declared} "
                              "(truncated?)")
        out.append(data)
    return out


def _check_accessor(gltf: Any, bufs: list[bytes], path: Path, index: object, what: str, *,
                    types: tuple[str, ...], count: int | None = None) -> int:
    """The accessor exists, has a known type and component type, and lies inside its buffer view
    and buffer; returns its element count."""
    accessors = gltf.accessors or []
    if not isinstance(index, int) or not 0 <= index < len(accessors):
        raise AvatarError(f"{path}: {what}: accessor {index} is not in the file ({len(accessors)} accessors)")
    acc = accessors[index]
    if acc.type not in types or acc.componentType not in COMPONENT:
        raise AvatarError(f"{path}: {what}: accessor {index} is {acc.type} of component type "
                          f"{acc.componentType}; expected {' or '.join(types)}")
    if count is not None and acc.count < count:
        raise AvatarError(f"{path}: {what}: accessor {index} has {acc.count} elements; expected {count}")
    if acc.bufferView is None:
        return int(acc.count)
    views = gltf.bufferViews or []
    if not 0 <= acc.bufferView < len(views):
        raise AvatarError(f"{path}: {what}: buffer view {acc.bufferView} is not in the file")
    view = views[acc.bufferView]
    if not 0 <= view.buffer < len(bufs):
        raise AvatarError(f"{path}: {what}: buffer {view.buffer} is not in the file")
    size = np.dtype(COMPONENT[acc.componentType]).itemsize * WIDTH[acc.type]
    stride = view.byteStride or size
    need = (acc.byteOffset or 0) + (acc.count - 1) * stride + size if acc.count else 0
    end = (view.byteOffset or 0) + view.byteLength
    if need > view.byteLength or end > len(bufs[view.buffer]):
        raise AvatarError(f"{path}: {what}: accessor {index} reaches past the end of its data "
                          "(a truncated or damaged file)")
    return int(acc.count)


def _check_primitive(gltf: Any, bufs: list[bytes], path: Path, prim: Any, what: str, bones: int) -> None:
    a = prim.attributes
    if a.POSITION is None or a.JOINTS_0 is None or a.WEIGHTS_0 is None:
        raise AvatarError(f"{path}: {what} has no "
                          f"{'POSITION' if a.POSITION is None else 'JOINTS_0/WEIGHTS_0'}")
    if prim.mode not in (None, 4):
        raise AvatarError(f"{path}: {what}: mode {prim.mode}: only triangles (4) are supported")
    n = _check_accessor(gltf, bufs, path, a.POSITION, f"{what} POSITION", types=("VEC3",))
    for key, types in (("NORMAL", ("VEC3",)), ("TEXCOORD_0", ("VEC2",)), ("WEIGHTS_0", ("VEC4",))):
        index = getattr(a, key)
        if index is not None:
            _check_accessor(gltf, bufs, path, index, f"{what} {key}", types=types, count=n)
    _check_accessor(gltf, bufs, path, a.JOINTS_0, f"{what} JOINTS_0", types=("VEC4",), count=n)
    used = accessor(gltf, bufs, a.JOINTS_0)
    if used.size and int(used.max()) >= bones:
        raise AvatarError(f"{path}: {what}: JOINTS_0 names bone {int(used.max())}; the skin has {bones}")
    if prim.indices is not None:
        m = _check_accessor(gltf, bufs, path, prim.indices, f"{what} indices", types=("SCALAR",))
        idx = accessor(gltf, bufs, prim.indices)
        if m % 3 or (idx.size and int(idx.max()) >= n):
            raise AvatarError(f"{path}: {what}: its indices are not triangles over its {n} vertices")
    elif n % 3:
        raise AvatarError(f"{path}: {what}: {n} vertices without indices are not whole triangles")
