"""The validation cases: a scene that reproduces a published experiment, where to measure it,
the real recording (when the user has it) and the published relation it is held against.

The scenes (``scenes/validation/``, written by ``bench/realism_scenes.py``) use each
experiment's own coordinates, so one measurement area and line serve the real
recording and every simulated run. The real recordings are not shipped with
pedvr (see :data:`DATA_HELP`); they are looked up under a data folder given by
``--data DIR`` or the environment variable ``PEDVR_REAL_DATA``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import shapely

from pedvr.measure import references as ref
from pedvr.measure.errors import MeasureError

DATA_ENV = "PEDVR_REAL_DATA"
DATA_HELP = (
    "real trajectories: a folder laid out as PedPy's notebooks/demo-data (github.com/PedestrianDynamics/"
    "PedPy): uni-directional/uo-070-180-180.txt, uo-100-180-180.txt, uo-145-180-180.txt; "
    "bottleneck/040_c_56_h-.txt; bi-directional/bi_corr_400_b_03.txt (the Jülich data archive, "
    "ped.fz-juelich.de/da, holds these experiments and more); give it with --data DIR or PEDVR_REAL_DATA"
)

Line = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class RealData:
    """A real recording: its file under the data folder, unit and frame rate where the file does not
    say, and the walkable area the experiment's analysis uses (PedPy's notebooks)."""

    file: str
    walkable: shapely.Polygon
    unit: str | None = None
    fps: float | None = None


@dataclass(frozen=True)
class Case:
    """One validation case. ``kind``: corridor, bottleneck, counterflow or door. ``width`` (m): the
    opening that meters the flow (entrance, bottleneck, door). ``published``: measure name ->
    reference value from a published relation, with ``published_source`` naming it."""

    name: str
    scene: str
    title: str
    kind: str
    width: float
    area: shapely.Polygon | None
    line: Line | None
    real: RealData | None = None
    published: dict[str, float] = field(default_factory=dict)
    published_source: str = ""
    duration: float = 120.0

    def scene_path(self) -> Path:
        from pedvr.scenes import resolve_scene

        p = resolve_scene(self.scene)
        if not p.is_file():
            raise MeasureError(f"case {self.name}: scene {self.scene} not found (scenes/validation/)")
        return p


UO_WALKABLE = shapely.Polygon(
    [
        (2.8, -6.5),
        (2.8, -4),
        (1.8, -4),
        (1.8, 4),
        (2.8, 4),
        (2.8, 8),
        (-1, 8),
        (-1, 4),
        (0, 4),
        (0, -4),
        (-1, -4),
        (-1, -6.5),
    ]
)
UO_AREA = shapely.box(0.0, -2.0, 1.8, 0.0)
UO_LINE: Line = ((0.0, 0.0), (1.8, 0.0))
BOTTLENECK_WALKABLE = shapely.Polygon(
    [(3.5, -2), (3.5, 8), (-3.5, 8), (-3.5, -2)],
    holes=[
        [
            (-0.7, -1.1),
            (-0.25, -1.1),
            (-0.25, -0.15),
            (-0.4, 0.0),
            (-2.8, 0.0),
            (-2.8, 6.7),
            (-3.05, 6.7),
            (-3.05, -0.3),
            (-0.7, -0.3),
        ],
        [
            (0.25, -1.1),
            (0.7, -1.1),
            (0.7, -0.3),
            (3.05, -0.3),
            (3.05, 6.7),
            (2.8, 6.7),
            (2.8, 0.0),
            (0.4, 0.0),
            (0.25, -0.15),
        ],
    ],
)
BI_WALKABLE = shapely.Polygon(
    [(-6.5, 6.5), (-6.5, -1.5), (5.5, -1.5), (5.5, 6.5)],
    holes=[[(-5, 0), (5, 0), (5, -1), (-5, -1)], [(-5, 4.1), (5, 4.1), (5, 5), (-5, 5)]],
)


def _corridor(entrance: float) -> Case:
    tag = f"{round(entrance * 100):03d}"
    return Case(
        name=f"uo_{tag}",
        scene=f"validation/uo_{tag}",
        kind="corridor",
        width=entrance,
        title=f"1.8 m corridor fed through a {entrance:.2f} m entrance",
        area=UO_AREA,
        line=UO_LINE,
        duration=120.0,
        real=RealData(
            file=f"uni-directional/uo-{tag}-180-180.txt", walkable=UO_WALKABLE, unit="cm", fps=16.0
        ),
        published_source="Weidmann 1993: speed at the run's own density",
    )


def _bottleneck(width: float) -> Case:
    tag = f"{round(width * 100):03d}"
    return Case(
        name=f"bottleneck_{tag}",
        scene=f"validation/bottleneck_{tag}",
        kind="bottleneck",
        width=width,
        title=f"{width:.2f} m bottleneck, 4 m long, 60 people",
        area=shapely.box(-0.5, 0.5, 0.5, 1.3),
        line=((width / 2 + 0.15, 0.0), (-width / 2 - 0.15, 0.0)),
        duration=90.0,
        published={"flow_per_s": ref.bottleneck_flow(width)},
        published_source="Seyfried et al. 2009: J = 1.9 b",
    )


CASES: dict[str, Case] = {
    c.name: c
    for c in [
        _corridor(0.7),
        _corridor(1.0),
        _corridor(1.45),
        Case(
            name="bottleneck_050",
            scene="validation/bottleneck_050",
            kind="bottleneck",
            width=0.5,
            title="0.5 m bottleneck, 75 people (Wuppertal 2018)",
            area=shapely.box(-0.4, 0.5, 0.4, 1.3),
            line=((0.4, 0.0), (-0.4, 0.0)),
            duration=100.0,
            real=RealData(file="bottleneck/040_c_56_h-.txt", walkable=BOTTLENECK_WALKABLE, unit="m"),
            published={"flow_per_s": ref.bottleneck_flow(0.5), "passed_share": 1.0},
            published_source="dense experiments: 1.1-1.2 /s through 0.5 m; everyone passes",
        ),
        *(_bottleneck(b) for b in (0.8, 0.9, 1.0, 1.1, 1.2)),
        Case(
            name="counterflow_400",
            scene="validation/counterflow_400",
            kind="counterflow",
            width=4.1,
            title="4.1 m corridor, counterflow, 480 people (BaSiGo)",
            area=shapely.box(-1.0, 0.0, 1.0, 4.1),
            line=((0.0, 0.0), (0.0, 4.1)),
            duration=140.0,
            real=RealData(file="bi-directional/bi_corr_400_b_03.txt", walkable=BI_WALKABLE, unit="cm"),
        ),
        Case(
            name="door_single_flow",
            scene="validation/door_single_flow",
            kind="door",
            width=1.1,
            title="single sprung door, 20 + 20 people arriving over 20 s",
            area=None,
            line=((0.0, -0.55), (0.0, 0.55)),
            duration=90.0,
            published={"passed_share": 1.0},
            published_source="issue 26's goal: everyone through well inside 90 s",
        ),
        Case(
            name="door_double_flow",
            scene="validation/door_double_flow",
            kind="door",
            width=2.0,
            title="double sprung door, 30 people from one side over 15 s",
            area=None,
            line=((0.0, -1.0), (0.0, 1.0)),
            duration=90.0,
            published={"passed_share": 1.0},
            published_source="issue 26's goal: everyone through, both leaves used",
        ),
    ]
}

DEFAULT_CASES = (
    "uo_070",
    "uo_100",
    "uo_145",
    "bottleneck_050",
    "bottleneck_080",
    "bottleneck_100",
    "bottleneck_120",
    "counterflow_400",
    "door_single_flow",
    "door_double_flow",
)


def get_case(name: str) -> Case:
    if name not in CASES:
        raise MeasureError(f"case {name!r}: unknown; known: {', '.join(CASES)}")
    return CASES[name]


def case_for_scene(scene_name: str) -> Case | None:
    """The case whose scene has this name (a recording's ``meta.scene``)."""
    for c in CASES.values():
        if Path(c.scene).name == scene_name:
            return c
    return None


def case_for_file(path: str | Path) -> Case | None:
    """The case whose real recording has this file name."""
    name = Path(path).name
    for c in CASES.values():
        if c.real is not None and Path(c.real.file).name == name:
            return c
    return None


def data_dir(given: str | Path | None) -> Path | None:
    """The real-data folder: ``given``, else ``$PEDVR_REAL_DATA``, else None. A folder that is
    named but missing is an error (one line), never silently skipped."""
    raw = given if given is not None else os.environ.get(DATA_ENV) or None
    if raw is None:
        return None
    p = Path(raw)
    if not p.is_dir():
        src = "--data" if given is not None else DATA_ENV
        raise MeasureError(f"{src} {p}: no such folder ({DATA_HELP})")
    return p


def real_file(case: Case, data: Path | None) -> Path | None:
    """The case's real recording under ``data``, or None when it is not there."""
    if case.real is None or data is None:
        return None
    p = data / case.real.file
    return p if p.is_file() else None
