"""``bench/paths.py`` runs and reports what it says (the figures themselves are not asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_paths_benchmark_reports_one_line_per_scene() -> None:
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "paths.py"), "--scenes", "office_doors",
                        "tradeshow", "--queries", "20"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert [row["scene"] for row in rows] == ["office_doors", "tradeshow"]
    for row in rows:
        assert row["triangles"] > 10 and 0 < row["queries"] <= 20
        assert 0 < row["ms_mean"] <= row["ms_p95"] * 10
        assert row["build_ms"] > 0 and row["locate_100_ms"] > 0
