"""pedvr: virtual pedestrians around a real person (see README.md and DESIGN.md)."""

import os as _os

__version__ = "0.2.0"

# numba's parallel kernels run on GNU OpenMP here. By default its idle worker
# threads spin before they sleep; when the cores are shared (a renderer, a
# compositor, the OpenXR runtime, another process) the spinning threads and
# the fork-joins fight over them and a parallel region of the ORCA step took
# 16 ms instead of 0.7 ms (issue 12; /tmp measurement in the commit that set
# this). Passive waiting: idle workers sleep at once. Set before numba loads
# OpenMP; a value the user exported wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# numba's cache, one folder per state of pedvr's source. numba checks a cached kernel against its
# own file's time stamp only, not against the files of the functions it calls (numba's documented
# limit; checked with numba 0.68.1: f in a.py calling g in b.py kept g's old code after b.py
# changed). pedvr's kernels call across files (the pose graph into pedvr/body/pose.py, ORCA into
# the neighbour search), so after a `git pull` or a branch switch in the README's editable install
# a kernel could run stale code, silently. Keyed by a digest of every .py file of the package
# (about 6 ms at import), a cache is never stale; editing any of them recompiles what a run uses
# (a minute or two, as `pedvr prepare` says). Folders beyond the newest four that have not been
# used for a day are removed. A NUMBA_CACHE_DIR the user exported wins.
_NUMBA_CACHE_KEEP = 4


def source_digest(root: str) -> str:
    """A digest of every ``.py`` file under ``root`` (paths and contents; not time stamps)."""
    import hashlib
    from pathlib import Path

    base = Path(root)
    h = hashlib.blake2b(digest_size=8)
    for p in sorted(base.rglob("*.py")):
        h.update(p.relative_to(base).as_posix().encode())
        h.update(b"\0")
        h.update(p.read_bytes())
    return h.hexdigest()


def numba_cache_dir(environ: "dict[str, str] | _os._Environ[str]", root: str) -> str | None:
    """The folder numba's cache goes to for the source under ``root`` (made, its siblings pruned),
    or None where ``environ`` names one already or none can be made."""
    import time

    if environ.get("NUMBA_CACHE_DIR"):
        return None
    base = environ.get("XDG_CACHE_HOME") or _os.path.join(_os.path.expanduser("~"), ".cache")
    parent = _os.path.join(base, "pedvr", "numba")
    path = _os.path.join(parent, f"{__version__}-{source_digest(root)}")
    try:
        _os.makedirs(path, exist_ok=True)
        _os.utime(path)  # in use now: the newest
    except OSError:
        return None  # no writable cache folder: numba's own default
    try:
        others = sorted((e for e in _os.scandir(parent) if e.is_dir() and e.path != path),
                        key=lambda e: e.stat().st_mtime, reverse=True)
        for e in others[_NUMBA_CACHE_KEEP - 1:]:
            if time.time() - e.stat().st_mtime > 86400.0:
                import shutil

                shutil.rmtree(e.path, ignore_errors=True)
    except OSError:
        pass
    return path


def _use_numba_cache_dir() -> None:
    import sys

    path = numba_cache_dir(_os.environ, _os.path.dirname(_os.path.abspath(__file__)))
    if path is None:
        return
    _os.environ["NUMBA_CACHE_DIR"] = path
    if "numba" in sys.modules:  # imported before pedvr: it read its configuration already
        sys.modules["numba"].core.config.reload_config()


_use_numba_cache_dir()
