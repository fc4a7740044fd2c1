"""numba compiles pedvr's kernels for one named CPU target, not the host (pedvr/__init__.py), so a
seed gives the same bytes on every x86-64-v3 machine: with the host's features, LLVM fused
a * b + c into one FMA where the CPU had it, and door_rush seed 8 ended at 73.8 s on one machine
and 87.2 s on another (stop 46; 88.0 s with NUMBA_CPU_NAME=generic on the first)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from pedvr import PORTABLE_CPU, numba_cpu

V3 = {f: True for f in ("avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave", "sse4.2")}


def _never() -> dict[str, bool]:
    raise AssertionError("the host's features are not asked for here")


def test_an_x86_64_v3_host_compiles_for_x86_64_v3_and_nothing_more() -> None:
    assert numba_cpu({}, "x86_64", lambda: V3) == {"NUMBA_CPU_NAME": PORTABLE_CPU, "NUMBA_CPU_FEATURES": ""}
    # AVX-512 on the host is not used: the same machine code as everywhere else
    big = dict(V3, avx512f=True, avx512bw=True, avx512vl=True)
    assert numba_cpu({}, "AMD64", lambda: big) == numba_cpu({}, "x86_64", lambda: V3)


def test_an_older_x86_64_host_gets_the_portable_generic_target() -> None:
    assert numba_cpu({}, "x86_64", lambda: dict(V3, fma=False)) == {"NUMBA_CPU_NAME": "generic",
                                                           "NUMBA_CPU_FEATURES": ""}
    assert numba_cpu({}, "x86_64", dict)["NUMBA_CPU_NAME"] == "generic"


def test_other_architectures_and_the_users_choice_are_left_alone() -> None:
    assert numba_cpu({}, "aarch64", _never) == {}
    assert numba_cpu({"NUMBA_CPU_NAME": "host"}, "x86_64", _never) == {}
    assert numba_cpu({"NUMBA_CPU_FEATURES": "+avx2"}, "x86_64", _never) == {}


_PROBE = """
import json, pedvr
from numba import njit
from numba.core.registry import cpu_target

@njit(fastmath={"contract"})
def f(a, b, c):
    return a * b + c

f(1.0, 2.0, 3.0)
asm = next(iter(f.inspect_asm().values()))
print(json.dumps({"magic": list(cpu_target.target_context.codegen().magic_tuple()),
                  "fma": "vfmadd" in asm}))
"""


def _probe(**env: str) -> dict[str, object]:
    e = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES")}
    e.update(env)
    out = subprocess.run([sys.executable, "-c", _PROBE], env=e, capture_output=True, text=True, timeout=120,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="x86-64 only")
def test_numba_compiles_for_the_named_target_after_import_pedvr() -> None:
    import llvmlite.binding as ll

    want = numba_cpu({}, platform.machine(), lambda: dict(ll.get_host_cpu_features()))
    got = _probe()
    assert got["magic"][1:] == [want["NUMBA_CPU_NAME"], ""]
    # FMA where the target has it (x86-64-v3), never from a host feature the target lacks
    assert got["fma"] is (want["NUMBA_CPU_NAME"] == PORTABLE_CPU)
    generic = _probe(NUMBA_CPU_NAME="generic")  # the user's choice wins
    assert generic["magic"][1] == "generic" and generic["fma"] is False
