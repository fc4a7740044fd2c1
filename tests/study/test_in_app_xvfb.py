"""The desktop in-app participant in a real glfw window under Xvfb (skipped without Xvfb): keys and a
mouse click answer a question on the panel, then a few frames of a trial render the scene."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.xr.test_desktop_xvfb import xvfb_display  # noqa: F401  (the fixture)

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import json
import glfw
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation
from pedvr.study.presenter import Page, Question
from pedvr.study.questionnaire import load_questionnaire
from pedvr.xr.participant import DesktopFrontend, InAppParticipant

fe = DesktopFrontend(width=320, height=240, vsync=False)
who = InAppParticipant(fe)
P, K = glfw.PRESS, lambda k: fe._on_key(None, k, 0, glfw.PRESS, 0)
script = [
    [lambda: K(glfw.KEY_ENTER)],                                  # the page
    [lambda: K(glfw.KEY_RIGHT), lambda: K(glfw.KEY_RIGHT)],       # choose 2
    [lambda: K(glfw.KEY_ENTER)], [lambda: K(glfw.KEY_BACKSPACE)],  # select, change
    [lambda: fe._on_char(None, ord("3"))], [lambda: K(glfw.KEY_ENTER)],
    [lambda: (K(glfw.KEY_Y), fe._on_char(None, ord("y")))],       # confirm 3
    [], ["click"], [lambda: fe._on_button(None, glfw.MOUSE_BUTTON_LEFT, P, 0)],  # click option 1, confirm
]
orig = fe.frame
def frame(sim, panel):
    if panel is not None and script:
        for f in script.pop(0):
            if f == "click":
                img, (x, y, w, h), view = fe._panel
                row = next(r for r, o in view.option_rows.items() if o == 1)
                y0, y1 = img.rows[row]
                glfw.set_cursor_pos(fe.window, x + w / 2, y + (y0 + y1) / 2 * h / img.image.shape[0])
                fe._on_button(None, glfw.MOUSE_BUTTON_LEFT, P, 0)
            else:
                f()
    return orig(sim, panel)
fe.frame = frame
who.show(Page(title="Welcome", text="Hello."))
ssq = load_questionnaire("user_study/questionnaires/ssq.toml")
q = Question(questionnaire=ssq, item=ssq.items[0], position=1, count=16)
out = {"first": who.ask(q).value, "second": who.ask(q).value}
scene = load_any(resolve_scene("headon_corridor"), seed=None)
sim = Simulation(scene, user_input=who.trial_input(trial=None, scene=scene))
for _ in range(5):
    sim.advance_to(max(who.present(sim), sim.t + sim.dt))
out["sim_t"] = sim.t
out["head_z"] = who.head_pose(sim).position[2]
fe.close()
out["closed"] = fe.closed
print(json.dumps(out))
"""


def test_desktop_participant_in_a_window(xvfb_display: str) -> None:  # noqa: F811
    r = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "DISPLAY": xvfb_display}, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["first"] == 3 and out["second"] == 1
    assert out["sim_t"] > 0 and out["closed"] is True
