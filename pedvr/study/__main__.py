"""``python -m pedvr.study run|export|analyze ...``: the study commands on their own."""

from __future__ import annotations

import sys

from pedvr.study.cli import main

sys.exit(main())
