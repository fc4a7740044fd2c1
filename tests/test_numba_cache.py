"""numba's cache is kept per state of pedvr's source (pedvr/__init__.py): numba checks a cached
kernel against its own file only, so a changed callee in another file left it stale."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pedvr
from pedvr import numba_cache_dir, source_digest


def _tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)


def test_the_digest_follows_contents_not_time_stamps(tmp_path: Path) -> None:
    _tree(tmp_path, {"a.py": "X = 1\n", "sub/b.py": "def f():\n    return 2\n", "notes.txt": "x"})
    d0 = source_digest(str(tmp_path))
    os.utime(tmp_path / "a.py", (0, 0))  # a checkout's time stamps: no change
    assert source_digest(str(tmp_path)) == d0
    (tmp_path / "notes.txt").write_text("y")  # not source
    assert source_digest(str(tmp_path)) == d0
    (tmp_path / "sub" / "b.py").write_text("def f():\n    return 3\n")  # a callee in another file
    assert source_digest(str(tmp_path)) != d0


def test_one_folder_per_source_and_old_ones_pruned(tmp_path: Path) -> None:
    src = tmp_path / "src"
    _tree(src, {"k.py": "A = 1\n"})
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    parent = tmp_path / "cache" / "pedvr" / "numba"
    first = numba_cache_dir(env, str(src))
    assert first is not None and Path(first).parent == parent and Path(first).is_dir()
    assert numba_cache_dir(env, str(src)) == first  # the same source, the same folder
    made = [first]
    for k in range(2, 8):  # six more states of the source, each older than a day when replaced
        old = time.time() - 3 * 86400
        for m in made:
            if Path(m).is_dir():  # pruned ones are gone
                os.utime(m, (old, old))
        (src / "k.py").write_text(f"A = {k}\n")
        made.append(numba_cache_dir(env, str(src)) or "")
    left = sorted(p.name for p in parent.iterdir())
    assert len(set(made)) == 7
    assert len(left) == 4  # the newest four
    assert Path(made[-1]).name in left


def test_a_recent_folder_is_kept_and_a_users_choice_wins(tmp_path: Path) -> None:
    src = tmp_path / "src"
    _tree(src, {"k.py": "A = 1\n"})
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    made = []
    for k in range(6):  # all used within the day: none removed
        (src / "k.py").write_text(f"A = {k}\n")
        made.append(numba_cache_dir(env, str(src)))
    assert all(Path(m or "").is_dir() for m in made)
    assert numba_cache_dir({"NUMBA_CACHE_DIR": str(tmp_path / "mine")}, str(src)) is None


def test_numba_uses_it_after_import(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = ("import numba, os\n"  # numba first: pedvr must make it read the folder again
            "import pedvr\n"
            "print(os.environ['NUMBA_CACHE_DIR']); print(numba.config.CACHE_DIR)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    env_dir, numba_dir = out.stdout.split()
    want = tmp_path / "pedvr" / "numba" / f"{pedvr.__version__}-{source_digest(os.path.dirname(pedvr.__file__))}"
    assert Path(env_dir) == want and Path(numba_dir) == want
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == [str(tmp_path / "mine")] * 2
