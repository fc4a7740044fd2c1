"""In the headset, pages and questions are fixed in the world (head-locked text is uncomfortable):
placed level in front of where the participant looks, kept while the head moves, put in front
again only after a large turn (drawn through each eye's own view: tests/render/test_panel_drawer.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.render.math3d import first_person_eye, project
from pedvr.render.panel import PANEL_DISTANCE, PanelAnchor
from pedvr.study.panel_input import PagePanel
from pedvr.study.presenter import Page
from pedvr.xr.participant import REANCHOR_DEG, XrFrontend
from pedvr.xr.session import SessionState, StateChanged
from tests.xr.test_session import FakePort, head_pose

W, H = 160, 100


def test_anchor_is_level_in_front_of_the_eye_even_when_looking_down() -> None:
    eye = first_person_eye(pos=np.array([2.0, 3.0]), heading=math.radians(30), pitch=math.radians(-40),
                           eye_height=1.6)
    a = PanelAnchor.facing(eye.view, eye.position)
    np.testing.assert_allclose(a.up, [0.0, 1.0, 0.0])
    assert a.right[1] == 0.0 and np.linalg.norm(a.right) == pytest.approx(1.0)
    d = a.center - eye.position
    assert d[1] == pytest.approx(0.0) and np.hypot(d[0], d[2]) == pytest.approx(PANEL_DISTANCE)
    # Straight ahead on the screen, when the eye looks level: its centre projects to the middle column.
    level = first_person_eye(pos=np.array([2.0, 3.0]), heading=math.radians(30), eye_height=1.6)
    col, _ = project(level.view_projection, a.center, width=W, height=H)
    assert col == pytest.approx(W / 2, abs=0.5)
    # Its right is the screen's right.
    col_r, _ = project(level.view_projection, a.center + 0.3 * a.right, width=W, height=H)
    assert col_r > col + 5


def test_xr_frontend_keeps_the_panel_where_it_was_put_until_a_large_turn() -> None:
    port = FakePort(events=[[StateChanged(SessionState.READY), StateChanged(SessionState.SYNCHRONIZED),
                             StateChanged(SessionState.VISIBLE), StateChanged(SessionState.FOCUSED)]])
    fe = XrFrontend(port=port)
    view = PagePanel(Page(title="Welcome", text="Look around."), keyboard=False).view()
    fe.frame(None, view)
    first = fe.anchor
    assert first is not None
    for yaw in (0.2, -0.4, math.radians(REANCHOR_DEG - 10)):  # looking around: the page stays
        port.head = head_pose(0.0, 0.0, yaw=yaw)
        fe.frame(None, view)
        assert fe.anchor is first
    port.head = head_pose(0.0, 0.0, yaw=math.radians(REANCHOR_DEG + 25))  # turned away: put in front again
    fe.frame(None, view)
    assert fe.anchor is not first
    moved = fe.anchor
    assert moved is not None
    fe.frame(None, None)  # a trial: no panel
    assert fe.anchor is None
    fe.close()
