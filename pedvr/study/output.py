"""Writing the toolkit's output folders (export, report): one clear line when it cannot be done.

A path that is a file, a folder that cannot be created or written, a file
that cannot be written: each is an :class:`~pedvr.study.errors.OutputError`
naming the path and the reason (``export/answers.tsv: cannot write: Permission
denied``), never a traceback. :func:`refuse_overwrite` lists files that
already exist unless the caller passed ``--force``.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable, Iterable
from pathlib import Path

from pedvr.study.errors import OutputError


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def prepare_folder(out: Path, *, what: str) -> None:
    """Create ``out`` (and parents) for ``what`` ("export", "report"); it must end up a writable folder."""
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: not a folder; the {what} needs a folder (give a new or existing folder)")
    for parent in (out, *out.parents):  # the nearest existing ancestor must not be a file either
        if parent.exists():
            if not parent.is_dir():
                raise OutputError(f"{out}: {parent} is a file, not a folder")
            break
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{out}: cannot create the {what} folder: {_why(exc)}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutputError(f"{out}: cannot write into the {what} folder: {os.strerror(errno.EACCES)}")


def refuse_overwrite(paths: Iterable[Path], *, force: bool) -> None:
    """Unless ``force``, an existing file among ``paths`` is an error that names it (and counts the rest)."""
    if force:
        return
    existing = [p for p in paths if p.exists()]
    if existing:
        more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
        raise OutputError(f"{existing[0]}: already exists{more}; use --force to overwrite")


def write_file(path: Path, write: Callable[[Path], object]) -> None:
    """Run ``write(path)``; an OSError becomes one line naming the file."""
    try:
        write(path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {_why(exc)}") from None


def make_folder(path: Path) -> None:
    try:
        path.mkdir(exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path}: cannot create the folder: {_why(exc)}") from None
