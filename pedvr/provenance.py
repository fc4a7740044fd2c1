"""Which code made a result (issue 25.8): pedvr's version and source tree, numpy, numba and dask.

Every row of a sweep's table carries :data:`COLUMNS`, measured on the worker
that ran it (:func:`provenance`, once per process: the code a process runs is
the code it imported when it started):

``pedvr_version``
    ``pedvr.__version__``.
``pedvr_git_commit``
    the commit of the git checkout pedvr runs from, or null when it is not
    one (a wheel install) or git is not there.
``pedvr_git_dirty``
    whether that checkout had uncommitted changes to the code (``pedvr/`` and
    ``pyproject.toml``, untracked files there included; documentation and
    scenes are not code: scene files are hashed into each run's key anyway).
``pedvr_git_diff``
    a hash of those changes (the diff against the commit and the untracked
    files' contents), so two dirty trees with the same edits compare equal
    and two with different edits do not; null when clean.
``numpy_version``, ``numba_version``, ``dask_version``
    as installed where the row was made.

Two provenances *differ* (:func:`differences`) where both know a field and
the values are not equal: a worker installed from a wheel (no commit) does
not differ from a checkout at the same version. ``pedvr sweep --resume``
refuses to add rows to a table whose rows differ from the running code unless
``--allow-mixed-code`` is given, and the report lists the code of every row.
"""

from __future__ import annotations

import functools
import hashlib
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

COLUMNS = (
    "pedvr_version",
    "pedvr_git_commit",
    "pedvr_git_dirty",
    "pedvr_git_diff",
    "numpy_version",
    "numba_version",
    "dask_version",
)
_CODE = ("pedvr", "pyproject.toml")  # what counts as code in the checkout


@functools.lru_cache(maxsize=1)
def provenance() -> dict[str, Any]:
    """This process's code (see the module docstring); computed once per process."""
    from pedvr import __version__

    out: dict[str, Any] = {"pedvr_version": __version__}
    out.update(_git(Path(__file__).resolve().parents[1]))
    for name in ("numpy", "numba", "dask"):
        try:
            out[f"{name}_version"] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[f"{name}_version"] = None
    return out


def _git(root: Path) -> dict[str, Any]:
    unknown: dict[str, Any] = {"pedvr_git_commit": None, "pedvr_git_dirty": None, "pedvr_git_diff": None}
    if not (root / ".git").exists() or not (root / "pedvr" / "__init__.py").is_file():
        return unknown

    def git(*args: str) -> bytes:
        cmd = ["git", "-C", str(root), *args]
        return subprocess.run(cmd, capture_output=True, check=True, timeout=30).stdout

    try:
        commit = git("rev-parse", "HEAD").decode().strip()
        status = git("status", "--porcelain", "--untracked-files=all", "--", *_CODE).decode()
        if not status.strip():
            return {"pedvr_git_commit": commit, "pedvr_git_dirty": False, "pedvr_git_diff": None}
        h = hashlib.sha256(git("diff", "HEAD", "--", *_CODE))
        for line in sorted(status.splitlines()):
            if line.startswith("?? "):
                name = line[3:].strip()
                h.update(name.encode() + b"\0")
                try:
                    h.update((root / name).read_bytes())
                except OSError:
                    pass
        return {"pedvr_git_commit": commit, "pedvr_git_dirty": True, "pedvr_git_diff": h.hexdigest()[:16]}
    except (OSError, subprocess.SubprocessError, UnicodeDecodeError):
        return unknown


def differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """``field old → new`` for each field both know and that differs."""
    out = []
    for k in COLUMNS:
        a, b = old.get(k), new.get(k)
        if a is not None and b is not None and a != b:
            out.append(f"{k} {_short(k, a)} → {_short(k, b)}")
    return out


def _short(key: str, v: Any) -> str:
    return str(v)[:12] if key == "pedvr_git_commit" else str(v)


def describe(p: dict[str, Any]) -> str:
    """``pedvr 0.2.0 at 1cd1c9c4 (uncommitted changes a1b2...), numpy 2.1.3, numba 0.61.0, dask 2025.1.0``."""
    if p.get("pedvr_git_commit"):
        where = f" at {str(p['pedvr_git_commit'])[:12]}"
        if p.get("pedvr_git_dirty"):
            where += f" with uncommitted changes ({p.get('pedvr_git_diff')})"
    else:
        where = " (commit unknown)"
    libs = ", ".join(f"{n} {p.get(f'{n}_version')}" for n in ("numpy", "numba", "dask"))
    return f"pedvr {p.get('pedvr_version')}{where}, {libs}"
