"""Finding shipped scenes by name (``pedvr run antipodal_circle``)."""

from __future__ import annotations

import sys
from pathlib import Path

DEFAULT_SCENE = "antipodal_circle"


def scene_dirs() -> list[Path]:
    """Where shipped scenes live: the source tree, then the installed data files."""
    here = Path(__file__).resolve().parent.parent / "scenes"
    return [d for d in (here, Path(sys.prefix) / "share" / "pedvr" / "scenes") if d.is_dir()]


def shipped_scenes() -> list[Path]:
    for d in scene_dirs():
        found = sorted(d.glob("*.toml"))
        if found:
            return found
    return []


def resolve_scene(arg: str | None) -> Path:
    """A path as given, or the shipped scene of that name."""
    if arg is None:
        arg = DEFAULT_SCENE
    p = Path(arg)
    if p.suffix in (".toml", ".xml") or p.exists():
        return p
    for d in scene_dirs():
        cand = d / f"{arg}.toml"
        if cand.is_file():
            return cand
    return p
