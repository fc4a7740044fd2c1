"""Shared fixtures: a shortened copy of the shipped protocol, and a small one."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
import tomli_w

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "user_study" / "pedvr_replication.toml"
DATA = Path(__file__).resolve().parent / "data"


def shortened_protocol(folder: Path, *, block_s: float = 0.4, corridor_s: float = 0.5, training_s: float = 0.3) -> Path:
    """The shipped protocol with short trials (the headless dry run of the tests); otherwise unchanged."""
    data = tomllib.loads(SHIPPED.read_text())
    data["study"]["questionnaire_dir"] = str(ROOT / "user_study" / "questionnaires")
    for step in data["steps"]:
        if step["kind"] == "trial":
            step["time_limit_s"] = training_s
            step["scene"] = str(ROOT / "user_study" / step["scene"])
        elif step["kind"] == "sweep":
            step["time_limit_s"] = corridor_s
        elif step["kind"] == "blocks":
            for b in step["blocks"]:
                b["time_limit_s"] = block_s
    out = folder / "pedvr_replication_short.toml"
    out.write_bytes(tomli_w.dumps(data).encode())
    return out


@pytest.fixture
def mini_protocol() -> Path:
    return DATA / "mini.toml"
