"""pedvr: virtual pedestrians around a real person (see README.md and DESIGN.md)."""

import os as _os
import typing as _typing

if _typing.TYPE_CHECKING:
    from collections.abc import Callable

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


# numba compiles for the host CPU by default: its name and every feature it has. The fastmath
# kernels let LLVM contract a * b + c into one fused multiply-add where the CPU has FMA, rounding
# once instead of twice, so one seed's run depended on the machine (stop 46: door_rush seed 8 ended
# at 73.8 s on one 2-core AMD EPYC VM and at 87.2 s on another; on the first, NUMBA_CPU_NAME=generic,
# without FMA, gave 88.0 s). pedvr has numba compile for one named target instead, x86-64-v3 (AVX2,
# FMA; every x86-64 server and desktop CPU since 2013-2015) with its own features and no others
# (no AVX-512 where the host has it), so the kernels are the same machine code on every such
# machine and a seed gives the same bytes there. An x86-64 CPU without those features gets
# numba's portable "generic"; other architectures keep the host. NUMBA_CPU_NAME or
# NUMBA_CPU_FEATURES exported by the user wins.
PORTABLE_CPU = "x86-64-v3"
_PORTABLE_FEATURES = ("avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave")


def numba_cpu(environ: "dict[str, str] | _os._Environ[str]", machine: str,
              host_features: "Callable[[], dict[str, bool]]") -> dict[str, str]:
    """The ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` pedvr sets for a host of ``machine``
    (``platform.machine()``) whose features ``host_features`` gives (llvmlite's names; asked only
    on x86-64): empty where ``environ`` names either already, or off x86-64."""
    if "NUMBA_CPU_NAME" in environ or "NUMBA_CPU_FEATURES" in environ:
        return {}
    if machine.lower() not in ("x86_64", "amd64"):
        return {}
    features = host_features()
    name = PORTABLE_CPU if all(features.get(f) for f in _PORTABLE_FEATURES) else "generic"
    return {"NUMBA_CPU_NAME": name, "NUMBA_CPU_FEATURES": ""}


def _host_features() -> "dict[str, bool]":
    import llvmlite.binding as ll  # numba loads it anyway

    return dict(ll.get_host_cpu_features())


def _use_numba_cpu() -> None:
    import platform
    import sys

    env = numba_cpu(_os.environ, platform.machine(), _host_features)
    if not env:
        return
    _os.environ.update(env)
    if "numba" in sys.modules:  # imported before pedvr: it read its configuration already
        sys.modules["numba"].core.config.reload_config()


_use_numba_cache_dir()
_use_numba_cpu()
