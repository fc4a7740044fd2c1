"""A glfw window under Xvfb opens, renders a frame, reads a pixel back and closes.

The test starts its own Xvfb (CI installs the ``xvfb`` package), so the rest of
the suite needs no display; without the Xvfb binary it is skipped, saying so.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture
def xvfb_display(monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb); the desktop window test needs an X server")
    for n in range(99, 140):
        if not Path(f"/tmp/.X11-unix/X{n}").exists() and not Path(f"/tmp/.X{n}-lock").exists():
            break
    proc = subprocess.Popen(
        [exe, f":{n}", "-screen", "0", "320x240x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 10
        while not Path(f"/tmp/.X11-unix/X{n}").exists():
            if proc.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"Xvfb :{n} did not start")
            time.sleep(0.05)
        monkeypatch.setenv("DISPLAY", f":{n}")
        monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
        yield f":{n}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


WINDOW_SCRIPT = """
import json
import math
from pedvr.render.renderer import SKY_LINEAR, srgb_encode_rgb
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation
from pedvr.xr.locomotion import KeyboardMouseUser
from pedvr.xr.loop import run_frames
from pedvr.xr.desktop import DesktopPresenter
from pedvr.xr.select import choose_backend

out = {"backend": choose_backend("desktop")[0]}
scene = load_any(resolve_scene("bidirectional_flow"), seed=None)  # outdoors: the sky shows
user = KeyboardMouseUser(start=scene.user.start, heading=scene.user.heading)
p = DesktopPresenter(scene, user=user, width=96, height=64, vsync=False, visible=True)
out["renderer"] = p.ctx.info["GL_RENDERER"]
sim = Simulation(scene, user_input=user)
out["period"] = p.wait_frame().period
sim.advance_to(0.05)
p.show_hud = False
p.render(sim)
out["sky"] = p.read_pixel(48, 1)
out["floor"] = p.read_pixel(48, 62)
out["expected_sky"] = [round(c * 255) for c in srgb_encode_rgb(SKY_LINEAR)]
p.end_frame()
tel = run_frames(sim, p, duration=0.3)
out["frames"] = tel.summary()["frames"]
out["sim_t"] = sim.t
p.close()
out["closed"] = p.closed
print(json.dumps(out))
"""


def _in_child(script: str, display: str) -> dict:
    """Run ``script`` on ``display`` and return the JSON of its last line. In a child process: a
    GLX window and the suite's EGL context cannot share one thread under Mesa, and an X error
    would end the whole test run."""
    r = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "DISPLAY": display},
    )
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_window_opens_renders_reads_a_pixel_and_closes(xvfb_display: str) -> None:
    out = _in_child(WINDOW_SCRIPT, xvfb_display)
    assert out["backend"] == "desktop" and out["period"] > 0
    assert all(abs(a - b) <= 3 for a, b in zip(out["sky"], out["expected_sky"], strict=True)), out
    assert out["floor"] != out["sky"]
    assert out["frames"] >= 1 and abs(out["sim_t"] - 0.3) < 0.012
    assert out["closed"] is True


INPUT_SCRIPT = """
import json, math, subprocess, time
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.xr.desktop import MOUSE_SENSITIVITY, DesktopPresenter
from pedvr.xr.locomotion import KeyboardMouseUser

scene = load_any(resolve_scene("headon_corridor"), seed=None)
user = KeyboardMouseUser(start=scene.user.start, heading=scene.user.heading)
p = DesktopPresenter(scene, user=user, width=96, height=64, vsync=True, visible=True)
glfw, win = p.glfw, p.window
out = {"sensitivity": MOUSE_SENSITIVITY}

def xdo(*args):
    subprocess.run(["xdotool", *args], check=True, timeout=10, capture_output=True)

def pump(until, seconds=3.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        p.wait_frame()  # polls glfw's events, as the frame loop does
        if until():
            return True
        time.sleep(0.01)
    return False

wid = subprocess.run(["xdotool", "search", "--name", "pedvr: headon_corridor"],
                     capture_output=True, text=True, check=True).stdout.split()[0]
xdo("windowfocus", "--sync", wid)
out["focused"] = pump(lambda: glfw.get_window_attrib(win, glfw.FOCUSED) == 1)
xdo("key", "F11")
out["fullscreen"] = pump(lambda: bool(glfw.get_window_monitor(win)))
out["fullscreen_size"] = list(glfw.get_framebuffer_size(win))
xdo("key", "F11")
out["windowed"] = pump(lambda: not glfw.get_window_monitor(win)
                       and tuple(glfw.get_framebuffer_size(win)) == (96, 64))
from pedvr.sim import Simulation
sim = Simulation(scene, user_input=user)
sim.advance_to(0.02)
p.show_hud = False

def hint_pixels():
    p.render(sim)
    return [list(p.read_pixel(x, 44)) for x in range(0, 96, 4)]

out["hint_before"], out["before"] = p.show_capture_hint, hint_pixels()
xdo("mousemove", "--window", wid, "48", "32")
xdo("click", "1")
out["captured"] = pump(lambda: glfw.get_input_mode(win, glfw.CURSOR) == glfw.CURSOR_DISABLED)
out["hint_after"], out["after"] = p.show_capture_hint, hint_pixels()
h0, p0 = user.heading, user.pitch
xdo("mousemove_relative", "--", "40", "-20")
pump(lambda: user.heading != h0 and user.pitch != p0)
out["turn"], out["look_up"] = user.heading - h0, user.pitch - p0
xdo("key", "Tab")
out["released"] = pump(lambda: glfw.get_input_mode(win, glfw.CURSOR) == glfw.CURSOR_NORMAL)
xdo("keydown", "w")
pump(lambda: user.velocity().any())
out["walk"] = user.velocity().tolist()
out["heading"] = user.heading
xdo("keydown", "shift")
pump(lambda: float((user.velocity() ** 2).sum()) > 2.0)
out["run_speed"] = float(math.hypot(*user.velocity()))
xdo("keyup", "shift", "w")
out["stopped"] = pump(lambda: not user.velocity().any())
xdo("key", "Escape")
out["esc_closes"] = pump(lambda: p.closed)
p.close()
print(json.dumps(out))
"""


def test_real_x_input_fullscreen_mouse_capture_keys_and_escape(xvfb_display: str) -> None:
    """Real X events (xdotool through the X server, not calls to our callbacks): F11 goes full
    screen on Xvfb's 320×240 screen and back, a hint says to click until a click captures the mouse,
    moving it turns and
    pitches the view by the sensitivity, Tab releases it, W walks forward at 1.3 m/s and Shift
    doubles it, Esc closes the window."""
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool is not installed (apt-get install xdotool; .ci/run installs it)")
    out = _in_child(INPUT_SCRIPT, xvfb_display)
    assert out["focused"] and out["fullscreen"] and out["windowed"], out
    assert out["fullscreen_size"] == [320, 240]
    assert out["captured"] and out["released"], out
    # Issue 11: until that first click the window says how to capture the mouse (a dark text panel
    # near the bottom); once captured the line is gone.
    assert out["hint_before"] and not out["hint_after"]
    dark = lambda row: sum(max(px) < 90 for px in row)  # noqa: E731
    assert dark(out["before"]) >= 8 and dark(out["after"]) <= 1, (out["before"], out["after"])
    k = out["sensitivity"]
    assert out["turn"] == pytest.approx(40 * k) and out["look_up"] == pytest.approx(20 * k)  # right, up
    walk = out["walk"]
    assert math.hypot(*walk) == pytest.approx(1.3)
    assert math.atan2(walk[1], walk[0]) == pytest.approx(out["heading"])  # forward is where it faces
    assert out["run_speed"] == pytest.approx(2.6)
    assert out["stopped"] and out["esc_closes"], out
