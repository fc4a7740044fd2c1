"""``pedvr bench realism`` as a script, and the merge of several of its JSON files into one table.

    python bench/realism.py --cases uo_070 --models pedvr decoupled --json   # = pedvr bench realism ...
    python bench/realism.py --merge a.json b.json [--json]                  # one table from split runs

Split runs (cases in parallel processes, each with --out FILE) merge into the table the README
quotes; the corridor cases' pooled slope comes from the file that ran them together.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any


def merge(files: list[Path]) -> dict[str, Any]:
    parts = [json.loads(f.read_text()) for f in files]
    models: list[str] = []
    for p in parts:
        models += [m for m in p["models"] if m not in models]
    out: dict[str, Any] = {
        "benchmark": "realism",
        "models": models,
        "data": next((p["data"] for p in parts if p.get("data")), None),
        "cases": [c for p in parts for c in p["cases"]],
        "corridor_pooled": next((p["corridor_pooled"] for p in parts if p.get("corridor_pooled")), {}),
        "wall_s": [p["wall_s"] for p in parts],
        "load_1min": [p["load_1min"] for p in parts],
        "files": [str(f) for f in files],
    }
    return out


def main(argv: list[str]) -> int:
    if argv and argv[0] == "--merge":
        rest = [a for a in argv[1:] if a != "--json"]
        result = merge([Path(a) for a in rest])
        if "--json" in argv:
            print(json.dumps(result, indent=2))
        else:
            from pedvr.measure.realism import table

            print(table(result))
        return 0
    from pedvr.cli import main as pedvr_main

    return pedvr_main(["bench", "realism", *argv])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
