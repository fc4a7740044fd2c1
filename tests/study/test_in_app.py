"""The in-app participant (``--backend desktop|xr``) without a window: a scripted frontend through a
whole session, the OpenXR frontend on a fake runtime, one offscreen (EGL) panel render, and the
one-line refusal when the backend cannot start."""

from __future__ import annotations

import io
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pedvr.crowd.user import UserInput
from pedvr.study.cli import main
from pedvr.study.console import ExperimenterConsole, NoKeys
from pedvr.study.panel_input import PanelEvent, PanelView, QuestionPanel
from pedvr.study.presenter import HeadPose, Page, Question, head_from_floor
from pedvr.study.protocol import load_protocol
from pedvr.study.questionnaire import Response, load_questionnaire
from pedvr.study.session import Session
from pedvr.study.store import StudyStore
from pedvr.xr.locomotion import Controls, KeyboardMouseUser
from pedvr.xr.participant import InAppParticipant, SessionClosed, StickChooser, XrFrontend, head_with_pitch

ROOT = Path(__file__).resolve().parents[2]
QDIR = ROOT / "user_study" / "questionnaires"


class FakeFrontend:
    """Answers every panel with its first option (``select`` then ``confirm``; text: types "ok");
    walks forward in trials; closes after ``close_after`` frames."""

    name = "fake"
    keyboard = True

    def __init__(self, close_after: int | None = None) -> None:
        self.frames = 0
        self.t = 50.0
        self.close_after = close_after
        self.panels: list[tuple[str, ...]] = []
        self.trials = 0
        self.user: KeyboardMouseUser | None = None

    @property
    def closed(self) -> bool:
        return self.close_after is not None and self.frames >= self.close_after

    def begin_trial(self, scene: Any) -> UserInput:
        self.trials += 1
        self.user = KeyboardMouseUser(start=scene.user.start, heading=scene.user.heading)
        self.user.set_keys(forward=1.0, strafe=0.0, fast=False)
        return self.user

    def frame(self, sim: Any, panel: PanelView | None) -> tuple[float | None, list[PanelEvent]]:
        self.frames += 1
        self.t += 1 / 60
        if panel is None:
            return self.t, []
        self.panels.append(panel.lines)
        if any(line.startswith("You chose") for line in panel.lines):
            return self.t, [PanelEvent("confirm")]
        if panel.option_rows or panel.highlight is None:
            return self.t, [PanelEvent("select")]
        return self.t, [PanelEvent("char", "o"), PanelEvent("char", "k"), PanelEvent("select")]

    def head_pose(self, sim: Any) -> HeadPose:
        return head_from_floor(sim, eye_height_m=1.6)

    def close(self) -> None:
        pass


def _session(store: StudyStore, participant: Any, *, resume: bool = False) -> Session:
    p = load_protocol(ROOT / "tests" / "study" / "data" / "mini.toml")
    console = ExperimenterConsole(out=io.StringIO(), keys=NoKeys(), live=False)
    return Session(protocol=p, store=store, participant_id="P03", participant=participant, console=console,
                   backend="desktop", resume=resume)


def test_a_whole_session_through_the_in_app_participant(tmp_path: Path) -> None:
    fe = FakeFrontend()
    with StudyStore(tmp_path / "s.sqlite") as store:
        res = _session(store, InAppParticipant(fe)).run()
    assert res.status == "finished"
    assert fe.trials == 5  # three conditions + the two-point sweep
    assert fe.panels[0][0] == "Hello." or "Hello." in fe.panels[0]
    with sqlite3.connect(tmp_path / "s.sqlite") as c:
        assert c.execute("SELECT participant_kind FROM sessions").fetchone() == ("in-app (fake)",)
        ssq = c.execute("SELECT DISTINCT raw_value FROM answers WHERE questionnaire = 'ssq'").fetchall()
        assert ssq == [(0.0,)]  # the first option, confirmed
        assert c.execute("SELECT text FROM answers WHERE item = 'comments'").fetchone() == ("ok",)
        # the user walked with the backend's input (forward at 1.3 m/s), not the scripted route
        (tid,) = c.execute("SELECT MIN(trial_id) FROM trials").fetchone()
        xy = np.array(c.execute("SELECT head_x, head_y, sim_t FROM samples WHERE trial_id = ? ORDER BY frame",
                                (tid,)).fetchall())
        assert xy.shape[0] > 10
        speed = np.linalg.norm(xy[-1, :2] - xy[0, :2]) / (xy[-1, 2] - xy[0, 2])
        assert speed == pytest.approx(1.3, rel=0.1)
        # frames follow the frontend's 60 Hz display clock
        assert np.diff(xy[:, 2]).mean() == pytest.approx(1 / 60, rel=0.2)


def test_closing_the_view_aborts_and_resume_continues(tmp_path: Path) -> None:
    db = tmp_path / "s.sqlite"
    with StudyStore(db) as store, pytest.raises(SessionClosed):
        _session(store, InAppParticipant(FakeFrontend(close_after=12))).run()
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT status FROM sessions").fetchone() == ("aborted",)
        n = c.execute("SELECT COUNT(*) FROM answers").fetchone()[0]
    assert n > 0
    with StudyStore(db) as store:
        assert _session(store, InAppParticipant(FakeFrontend()), resume=True).run().status == "finished"


def test_head_pose_pitch() -> None:
    base = HeadPose(position=(0.0, 0.0, 1.6), orientation=(1.0, 0.0, 0.0, 0.0))
    q = np.array(head_with_pitch(base, heading=0.0, pitch=np.pi / 2).orientation)
    w, x, y, z = q
    # rotate the forward axis (1, 0, 0): looking straight up gives (0, 0, 1)
    fwd = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)])
    assert fwd == pytest.approx([0.0, 0.0, 1.0], abs=1e-9)


# -- the OpenXR frontend on a fake runtime ------------------------------------------------------


def test_stick_fires_once_per_push() -> None:
    s = StickChooser()
    got = [e.kind for x in (0.9, 0.95, 0.5, 0.1, 0.8, -0.2, -0.9) for e in s.feed(x)]
    assert got == ["next", "next", "prev"]


def test_xr_frontend_answers_with_the_controller() -> None:
    from pedvr.xr.session import SessionState, StateChanged
    from tests.xr.test_session import FakePort

    port = FakePort(
        events=[[StateChanged(SessionState.READY), StateChanged(SessionState.SYNCHRONIZED),
                 StateChanged(SessionState.VISIBLE), StateChanged(SessionState.FOCUSED)]],
        controls=[Controls(trigger=True),  # the page
                  Controls(move=(0.9, 0.0)), Controls(move=(0.9, 0.0)), Controls(), Controls(turn=0.8),
                  Controls(trigger=True), Controls(menu=True),  # confirming -> back to choosing
                  Controls(move=(-0.9, 0.0)), Controls(trigger=True), Controls(trigger=True)],
    )
    fe = XrFrontend(port=port)
    assert fe.drawer is None  # the fake runtime has no GL context: nothing is drawn
    who = InAppParticipant(fe)
    who.show(Page(title="Welcome", text="Put on the headset."))
    ssq = load_questionnaire(QDIR / "ssq.toml")
    q = Question(questionnaire=ssq, item=ssq.items[0], position=1, count=16)
    assert who.ask(q) == Response(value=1)
    assert port.rendered and set(port.rendered) == {0, 1}  # both eyes every frame
    assert QuestionPanel(q, keyboard=False).view().lines[-1].startswith("Thumbstick")
    fe.close()
    assert "close" in port.calls


# -- drawn offscreen --------------------------------------------------------------------------


def test_questionnaire_panel_renders_offscreen_egl() -> None:
    moderngl = pytest.importorskip("moderngl")
    from pedvr.render.panel import CLEAR, PanelDrawer, panel_image, row_at

    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # pragma: no cover - no EGL on this machine
        pytest.skip(f"no EGL context: {exc}")
    ssq = load_questionnaire(QDIR / "ssq.toml")
    panel = QuestionPanel(Question(questionnaire=ssq, item=ssq.items[0], position=1, count=16))
    panel.feed(PanelEvent("next"))
    view = panel.view()
    img = panel_image(view.lines, highlight=view.highlight, font_size=20, width_px=480)
    w, h = 320, 240
    fbo = ctx.simple_framebuffer((w, h))
    drawer = PanelDrawer(ctx)
    drawer.clear(fbo, (0, 0, w, h))
    x, y, pw, ph = drawer.draw(img, framebuffer=fbo, viewport=(0, 0, w, h), fraction=0.9)
    px = np.frombuffer(fbo.read(components=3), np.uint8).reshape(h, w, 3)[::-1]  # top row first
    drawer.release()
    ctx.release()
    assert 0 < x and 0 < y and x + pw < w and y + ph < h
    outside = px[2, 2].astype(int)
    assert np.abs(outside - np.round(np.array(CLEAR) * 255)).max() <= 2
    inside = px[y:y + ph, x:x + pw].astype(int)
    bright = (inside.min(axis=2) > 160).sum()  # white glyphs
    dark = (inside.max(axis=2) < 50).sum()  # the panel's background
    blue = ((inside[..., 2] > 120) & (inside[..., 0] < 90)).sum()  # the highlighted option's band
    assert bright > 100 and dark > 0.3 * pw * ph and blue > 200
    # text sits where the panel is: no glyph-white outside it
    mask = np.ones((h, w), bool)
    mask[y:y + ph, x:x + pw] = False
    assert (px[mask].min(axis=1) > 160).sum() == 0
    # a click on the highlighted row picks that option
    y0, y1 = img.rows[view.highlight]  # type: ignore[index]
    cy = y + (y0 + y1) / 2 * ph / img.image.shape[0]
    row = row_at(img, (x, y, pw, ph), x + pw / 2, cy)
    assert row == view.highlight and view.option_rows[row] == 1


# -- the backend cannot start: one line ---------------------------------------------------------


@pytest.mark.parametrize("backend", ["xr", "desktop"])
def test_backend_that_cannot_start_is_one_line(backend: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    rc = main(["run", str(ROOT / "tests" / "study" / "data" / "mini.toml"), "--participant", "P01",
               "--backend", backend, "--db", str(tmp_path / "x.sqlite")])
    err = capsys.readouterr().err
    assert rc != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("pedvr: error: cannot ") and lines[0].endswith(
        ("use --backend headless", "use --backend headless (or --backend desktop)"))
    assert "Traceback" not in err and not (tmp_path / "x.sqlite").exists()


def test_simulated_participant_refuses_a_view(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["run", str(ROOT / "tests" / "study" / "data" / "mini.toml"), "--participant", "simulated",
               "--backend", "desktop", "--db", str(tmp_path / "x.sqlite")])
    assert rc != 0 and "a simulated participant runs headless" in capsys.readouterr().err
