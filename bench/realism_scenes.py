# ruff: noqa: E501  (the TOML templates keep their lines as the files show them)
"""Write scenes/validation/*.toml: pedvr scenes that reproduce published experiments (issue 26).

    python bench/realism_scenes.py            # rewrites the files; review the diff

Each scene uses the experiment's own coordinates, so the measurement area and
line of the real data (pedvr.measure.cases) apply to the simulated run
unchanged. Geometry sources and pedvr's choices (where the papers and
notebooks leave something open) are written into each file's header.
"""

from __future__ import annotations

import math
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "scenes" / "validation"

PROFILE = """[agents.profiles.person]
radius = 0.25      # pedvr's default shoulder disc (0.5 m across)
pref_speed = 1.34  # Weidmann (1993): mean free walking speed
max_speed = 1.7
"""


def _box(b: tuple[float, float, float, float], kind: str = "wall", height: float = 2.2) -> str:
    return f"""[[world.obstacles]]
kind = "{kind}"
box = [{b[0]:.3f}, {b[1]:.3f}, {b[2]:.3f}, {b[3]:.3f}]
height = {height}
"""


def _poly(pts: list[tuple[float, float]], height: float = 2.2) -> str:
    inner = ", ".join(f"[{x}, {y}]" for x, y in pts)
    return f"""[[world.obstacles]]
kind = "wall"
polygon = [{inner}]
height = {height}
"""


USER_OFF = """[user]
start = [0.0, 0.0]
enabled = false    # a validation run has no participant in it
"""


def corridor(entrance: float, people: int) -> str:
    """Jülich uni-directional corridor (Zhang et al. 2011, PedPy's fundamental_diagram.ipynb):
    corridor x in [0, 1.8], y in [-4, 4], walked toward -y; a 3.8 m wide passage y in [4, 8]
    before it and the exit area y in [-6.5, -4] after it, as the notebook's walkable area.
    pedvr's choices: the entrance (width b, centred on the corridor, x = 0.9) is a gap in a wall
    at y = 8, where the recorded trajectories begin with the entrance's spread; the holding area
    behind it is 8 m x 14 m (the paper gives no size; large enough to place everyone at under
    1 person/m², so the entrance alone meters the inflow)."""
    b = entrance
    lo, hi = 0.9 - b / 2, 0.9 + b / 2
    name = f"uo_{round(b * 100):03d}"
    return f"""# Jülich uni-directional corridor, entrance {b:.2f} m, corridor 1.8 m, exit 1.8 m, {people} people
# (experiment uo-{round(b * 100):03d}-180-180; Zhang et al. 2011, J. Stat. Mech. P06004; geometry as in
# PedPy's notebooks/fundamental_diagram.ipynb). Everyone starts in the holding area (y > 8.2) and walks
# through the entrance, the 8 m corridor (x 0..1.8, y 4..-4) and out at y < -5.6 (a sink).
# Measured (pedvr.measure.cases): area x 0..1.8, y -2..0; line y = 0. Written by bench/realism_scenes.py.
[scene]
name = "{name}"
description = "Jülich corridor: {people} people through a {b:.2f} m entrance into a 1.8 m corridor."
seed = 1
duration = 120.0

[world]
bounds = [[-3.1, -6.5], [4.9, 22.2]]
indoor = true
floor = "tiles"

{_box((-3.1, -6.5, -1.0, 8.0))}
{_box((2.8, -6.5, 4.9, 8.0))}
{_box((-1.0, -4.0, 0.0, 4.0))}
{_box((1.8, -4.0, 2.8, 4.0))}
{_box((-3.1, 8.0, lo, 8.2))}
{_box((hi, 8.0, 4.9, 8.2))}
{PROFILE}
[[agents.spawns]]
profile = "person"
state = "walk"
count = {people}
region = {{ box = [-2.8, 8.6, 4.6, 21.9] }}

[[agents.sinks]]
region = {{ box = [-1.0, -6.5, 2.8, -5.6] }}

[behavior.states.walk]
goal = {{ selector = "region", box = [-0.7, -6.4, 2.5, -6.0] }}

{USER_OFF}"""


BARRIER_L = [(-0.7, -1.1), (-0.25, -1.1), (-0.25, -0.15), (-0.4, 0.0), (-2.8, 0.0), (-2.8, 6.7),
             (-3.05, 6.7), (-3.05, -0.3), (-0.7, -0.3)]
BARRIER_R = [(0.25, -1.1), (0.7, -1.1), (0.7, -0.3), (3.05, -0.3), (3.05, 6.7), (2.8, 6.7), (2.8, 0.0),
             (0.4, 0.0), (0.25, -0.15)]


def _hex(n: int, *, x0: float, x1: float, y0: float, dx: float = 0.62, dy: float = 0.55) -> list[tuple[float, float]]:
    """``n`` points of a staggered grid in x0..x1 from y0 upward, the ``n`` nearest the origin."""
    pts = []
    row = 0
    while len(pts) < 2 * n:
        shift = 0.0 if row % 2 == 0 else dx / 2
        x = x0 + shift
        while x <= x1 + 1e-9:
            pts.append((round(x, 3), round(y0 + row * dy, 3)))
            x += dx
        row += 1
    pts.sort(key=lambda p: (math.hypot(p[0], p[1]), p[1], p[0]))
    return sorted(pts[:n], key=lambda p: (p[1], p[0]))


def bottleneck_wuppertal() -> str:
    """Wuppertal 2018 bottleneck 040_c_56_h- (PedPy's user_guide.ipynb): a 0.5 m wide, 1 m long
    bottleneck (x -0.25..0.25, y -1.1..0) below a 5.6 m wide waiting area; 75 people. The barriers
    are the notebook's obstacle polygons. pedvr's choice: the 75 start on a staggered grid 0.62 m x
    0.55 m (about 2.9 persons/m², as packed as the recording's first frame), nearest the opening."""
    pts = _hex(75, x0=-2.17, x1=2.17, y0=0.45)
    positions = ",\n             ".join(f"[{x}, {y}]" for x, y in pts)
    return f"""# Wuppertal 2018 bottleneck (040_c_56_h-, PedPy's demo data; Adrian et al. 2020): 75 people in a 5.6 m
# wide waiting area pass a 0.5 m wide, 1 m long bottleneck (x -0.25..0.25, y -1.1..0) walking toward -y.
# Geometry: the barrier polygons of PedPy's notebooks/user_guide.ipynb. Measured: line y = 0 across the
# bottleneck's mouth, area x -0.4..0.4, y 0.5..1.3 in front of it. Written by bench/realism_scenes.py.
[scene]
name = "bottleneck_050"
description = "Wuppertal 2018: 75 people through a 0.5 m bottleneck."
seed = 1
duration = 100.0

[world]
bounds = [[-3.5, -2.0], [3.5, 8.0]]
indoor = true
floor = "tiles"

{_poly(BARRIER_L)}
{_poly(BARRIER_R)}
{PROFILE}
[[agents.spawns]]
profile = "person"
state = "walk"
positions = [{positions}]

[[agents.sinks]]
region = {{ box = [-3.5, -2.0, 3.5, -1.5] }}

[behavior.states.walk]
goal = {{ selector = "region", box = [-1.0, -1.74, 1.0, -1.6] }}

{USER_OFF}"""


def bottleneck_seyfried(width: float, people: int = 60) -> str:
    """Seyfried et al. 2009 (Transportation Science 43(3)): bottlenecks 0.8-1.2 m wide and 4 m long,
    60 people starting in a holding area 3 m in front of the bottleneck. pedvr's choices where the
    paper leaves it open: the corridor in front of the bottleneck is 4 m wide, and the 60 start on
    the staggered grid of the Wuppertal case (0.62 m x 0.55 m, about 2.9 persons/m²) from 3 m in
    front of the mouth. Same frame as the Wuppertal case: the mouth is the line y = 0, walked toward
    -y."""
    b = width
    name = f"bottleneck_{round(b * 100):03d}"
    pts = _hex(people, x0=-1.55, x1=1.55, y0=3.0)
    positions = ",\n             ".join(f"[{x}, {y}]" for x, y in pts)
    return f"""# Bottleneck {b:.2f} m wide, 4 m long, {people} people (Seyfried et al. 2009, "New insights into pedestrian
# flow through bottlenecks", Transportation Science 43(3)). The people start 3 m in front of the
# bottleneck's mouth (y = 0) in a 4 m wide corridor and walk toward -y; the bottleneck runs y 0..-4; out at
# y < -5.5 (a sink). pedvr's choices where the paper leaves it open: the corridor's width (4 m) and the
# start grid (2.9 persons/m²). Measured: line y = 0 (the mouth), area 1 m x 0.8 m in front of it.
# Written by bench/realism_scenes.py.
[scene]
name = "{name}"
description = "Seyfried et al. 2009: {people} people through a {b:.2f} m wide, 4 m long bottleneck."
seed = 1
duration = 90.0

[world]
bounds = [[-2.0, -6.5], [2.0, 9.2]]
indoor = true
floor = "tiles"

{_box((-2.0, -4.0, -b / 2, 0.0))}
{_box((b / 2, -4.0, 2.0, 0.0))}
{PROFILE}
[[agents.spawns]]
profile = "person"
state = "walk"
positions = [{positions}]

[[agents.sinks]]
region = {{ box = [-2.0, -6.5, 2.0, -5.5] }}

[behavior.states.walk]
goal = {{ selector = "region", box = [-1.0, -6.4, 1.0, -6.0] }}

{USER_OFF}"""


def counterflow() -> str:
    """BaSiGo bi-directional corridor bi_corr_400_b_03 (PedPy's fundamental_diagram_at_measurement_line
    notebook): a 4.1 m wide, 10 m long corridor (walls at y = 0 and y = 4.1, x -5..5); 231 people walk
    east and 249 west. In the recording people enter from both ends over two minutes: the sources
    reproduce that metered inflow (east 1.94/s from 3.76 s, west 2.16/s from 5.92 s: the recording's
    first appearances), 1.2 m before the corridor's ends; the sinks lie 1.3 m behind the other way's
    sources, so that nobody who just entered is pushed into a sink before crossing."""
    return f"""# BaSiGo bi-directional corridor (bi_corr_400_b_03, PedPy's demo data; Holl et al.): 480 people, 231
# walking east and 249 west through a 4.1 m wide, 10 m long corridor (x -5..5, y 0..4.1). The inflow of
# the recording is metered at both ends (sources: east 1.94/s from t = 3.76 s, west 2.16/s from 5.92 s,
# the recording's first appearances) 1.2 m before the corridor's ends; people leave 2.5 m past the far
# end (sinks), 1.3 m behind where the people walking the other way enter: none of those is pushed into one.
# Measured: area x -1..1 across the corridor; line x = 0. Written by bench/realism_scenes.py.
[scene]
name = "counterflow_400"
description = "BaSiGo counterflow: 231 east and 249 west through a 4.1 m corridor, metered inflow."
seed = 1
duration = 140.0

[world]
bounds = [[-8.0, -1.5], [8.0, 5.6]]
indoor = true
floor = "tiles"

{_box((-5.0, -1.5, 5.0, 0.0))}
{_box((-5.0, 4.1, 5.0, 5.6))}
{PROFILE}
[[agents.sources]]
profile = "person"
state = "east"
rate = 1.94
start = 3.76
max_count = 231
line = [[-6.2, 0.4], [-6.2, 3.7]]

[[agents.sources]]
profile = "person"
state = "west"
rate = 2.16
start = 5.92
max_count = 249
line = [[6.2, 0.4], [6.2, 3.7]]

[[agents.sinks]]
region = {{ box = [7.5, -1.5, 8.0, 5.6] }}

[[agents.sinks]]
region = {{ box = [-8.0, -1.5, -7.5, 5.6] }}

[behavior.states.east]
goal = {{ selector = "region", box = [7.6, 0.5, 7.74, 3.6] }}

[behavior.states.west]
goal = {{ selector = "region", box = [-7.74, 0.5, -7.6, 3.6] }}

{USER_OFF}"""


def door(kind: str) -> str:
    """A sprung door in a wall at x = 0 (as scenes/door_opposing.toml and door_double.toml): the
    single door 1.1 m, 20 people arriving from each side over 20 s (issue 26's case); the double
    door 2.0 m, 30 people arriving from the west at 2/s, so that a queue forms."""
    half = 0.55 if kind == "single" else 1.0
    name = f"door_{kind}_flow"
    if kind == "single":
        sources = """[[agents.sources]]
profile = "person"
state = "east"
rate = 1.0
max_count = 20
region = { box = [-8.5, -3.5, -7.0, 3.5] }

[[agents.sources]]
profile = "person"
state = "west"
rate = 1.0
max_count = 20
region = { box = [7.0, -3.5, 8.5, 3.5] }
"""
        what = "20 people from each side arriving over 20 s through a 1.1 m sprung single door"
    else:
        sources = """[[agents.sources]]
profile = "person"
state = "east"
rate = 2.0
max_count = 30
region = { box = [-8.5, -3.5, -7.0, 3.5] }
"""
        what = "30 people from the west arriving over 15 s at a 2.0 m sprung double door"
    return f"""# {what} (issue 26). Door etiquette on (Huang & Terzopoulos); the leaves are pulled open from the west.
# Measured: line x = 0 through the doorway (who passed, flow, time gaps). Written by bench/realism_scenes.py.
[scene]
name = "{name}"
description = "{what}."
seed = 1
duration = 90.0

[world]
bounds = [[-9.0, -5.0], [9.0, 5.0]]
indoor = true
ceiling = true
floor = "tiles"

[[world.obstacles]]
kind = "wall"
wall = [[0.0, -5.0], [0.0, -{half}]]
height = 2.6

[[world.obstacles]]
kind = "wall"
wall = [[0.0, {half}], [0.0, 5.0]]
height = 2.6

[[world.doors]]
name = "main"
kind = "{kind}"
span = [[0.0, -{half}], [0.0, {half}]]
pull_side = [-1.0, 0.0]

{PROFILE}
{sources}
# Each room's exit is for the people leaving through it: one queued near where it came in, pushed
# back into the sink behind it, stays (door_single_flow seed 13 lost one that way, never through).
[[agents.sinks]]
region = {{ box = [8.6, -5.0, 9.0, 5.0] }}
states = ["east"]

[[agents.sinks]]
region = {{ box = [-9.0, -5.0, -8.6, 5.0] }}
states = ["west"]

[behavior.states.east]
goal = {{ selector = "region", box = [8.7, -3.0, 8.9, 3.0] }}

[behavior.states.west]
goal = {{ selector = "region", box = [-8.9, -3.0, -8.7, 3.0] }}

{USER_OFF}"""


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    files = {f"uo_{round(b * 100):03d}.toml": corridor(b, n) for b, n in ((0.7, 111), (1.0, 121), (1.45, 175))}
    files["bottleneck_050.toml"] = bottleneck_wuppertal()
    for b in (0.8, 0.9, 1.0, 1.1, 1.2):
        files[f"bottleneck_{round(b * 100):03d}.toml"] = bottleneck_seyfried(b)
    files["counterflow_400.toml"] = counterflow()
    files["door_single_flow.toml"] = door("single")
    files["door_double_flow.toml"] = door("double")
    for name, text in files.items():
        (OUT / name).write_text(text.rstrip() + "\n")
        print(OUT / name)


if __name__ == "__main__":
    main()
