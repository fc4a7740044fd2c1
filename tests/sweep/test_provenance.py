"""Issue 25.8: every row says which code made it, and --resume does not mix codes without saying so."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numba
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import pedvr
from pedvr.cli import main
from pedvr.provenance import COLUMNS, describe, differences, provenance
from pedvr.sweep.errors import SweepError
from pedvr.sweep.runner import run_sweep
from pedvr.sweep.spec import load_spec
from pedvr.sweep.table import read_table
from tests.sweep.conftest import SMALL, write_spec

ROOT = Path(pedvr.__file__).resolve().parents[1]


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True).stdout


def test_rows_carry_the_code_that_made_them(tmp_path: Path) -> None:
    import dask

    spec = load_spec(write_spec(tmp_path, SMALL.format(duration=0.2).replace("[1, 2, 3, 4]", "[1]")))
    assert run_sweep(spec, out=tmp_path / "o", workers=0, progress=False).ok == 3
    df = read_table(tmp_path / "o").to_pandas()
    assert set(COLUMNS) <= set(df.columns)
    row = df.iloc[0]
    assert row["pedvr_version"] == pedvr.__version__ == "0.2.0"
    assert (row["numpy_version"], row["numba_version"], row["dask_version"]) == (
        np.__version__,
        numba.__version__,
        dask.__version__,
    )
    if (ROOT / ".git").exists():
        assert row["pedvr_git_commit"] == _git("rev-parse", "HEAD").strip()
        dirty = bool(
            _git("status", "--porcelain", "--untracked-files=all", "--", "pedvr", "pyproject.toml").strip()
        )
        assert row["pedvr_git_dirty"] == dirty and pd.isna(row["pedvr_git_diff"]) != dirty
    assert df[list(COLUMNS)].nunique(dropna=False).max() == 1  # one code for the whole sweep


def test_provenance_differs_only_where_both_know() -> None:
    mine = provenance()
    wheel = {**mine, "pedvr_git_commit": None, "pedvr_git_dirty": None, "pedvr_git_diff": None}
    assert differences(wheel, mine) == [] and differences(mine, wheel) == []
    other = {**mine, "pedvr_git_commit": "0" * 40, "numba_version": "0.1"}
    assert (
        differences(other, mine)
        == [
            f"pedvr_git_commit 000000000000 → {str(mine['pedvr_git_commit'])[:12]}",
            f"numba_version 0.1 → {mine['numba_version']}",
        ]
        if mine["pedvr_git_commit"]
        else [f"numba_version 0.1 → {mine['numba_version']}"]
    )
    assert describe(
        {**mine, "pedvr_git_commit": "abcdef0123456789", "pedvr_git_dirty": True, "pedvr_git_diff": "feed"}
    ).startswith(f"pedvr {pedvr.__version__} at abcdef012345 with uncommitted changes (feed), numpy ")


def test_resume_refuses_rows_from_other_code_unless_allowed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_spec(tmp_path, SMALL.format(duration=0.2).replace("[1, 2, 3, 4]", "[1]"))
    spec = load_spec(path)
    out = tmp_path / "o"
    assert run_sweep(spec, out=out, workers=0, progress=False).ok == 3
    # Two rows made "by numpy 1.0.0", one row missing (a sweep that stopped part way).
    table = read_table(out).slice(0, 2)
    col = table.column_names.index("numpy_version")
    table = table.set_column(col, "numpy_version", pa.array(["1.0.0"] * 2, pa.string()))
    pq.write_table(table, out / "runs.parquet")
    why = f"2 rows: numpy_version 1.0.0 → {np.__version__}"
    with pytest.raises(
        SweepError,
        match=rf"its rows were made by other code than this \({why}\); resume with "
        r"--allow-mixed-code",
    ):
        run_sweep(spec, out=out, resume=True, workers=0, progress=False)
    assert main(["sweep", str(path), "--out", str(out), "--resume", "--workers", "0", "--quiet"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"pedvr: error: {out}: its rows were made by other code than this ({why}); resume with "
        "--allow-mixed-code to add rows anyway (each row records its code), or choose another --out"
    ]
    assert main(["sweep", str(path), "--out", str(out), "--allow-mixed-code", "--workers", "0"]) == 2
    assert "--allow-mixed-code applies to --resume" in capsys.readouterr().err
    assert (
        main(
            [
                "sweep",
                str(path),
                "--out",
                str(out),
                "--resume",
                "--allow-mixed-code",
                "--workers",
                "0",
                "--quiet",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert f"note: the table now holds rows from different code (--allow-mixed-code): {why}" in printed
    assert f"code: {describe(provenance())}" in printed
    assert sorted(read_table(out).column("numpy_version").to_pylist()) == sorted(
        ["1.0.0", "1.0.0", np.__version__]
    )


def test_the_report_says_when_rows_come_from_different_code(tmp_path: Path) -> None:
    from pedvr.sweep.report import write_sweep_report

    spec = load_spec(write_spec(tmp_path, SMALL.format(duration=0.2).replace("[1, 2, 3, 4]", "[1]")))
    out = tmp_path / "o"
    assert run_sweep(spec, out=out, workers=0, progress=False).ok == 3
    assert f"Code: {describe(provenance())}." in write_sweep_report(out).read_text()
    table = read_table(out)
    col = table.column_names.index("numpy_version")
    table = table.set_column(col, "numpy_version", pa.array(["1.0.0", np.__version__, np.__version__]))
    pq.write_table(table, out / "runs.parquet")
    text = write_sweep_report(out).read_text()
    assert "**Code: the ok rows were made by 2 different codes** (`--allow-mixed-code`):" in text
    assert f"- 2 rows: {describe(provenance())}" in text
    assert f"- 1 row: {describe({**provenance(), 'numpy_version': '1.0.0'})}" in text
