"""Waiting regions of Huang & Terzopoulos Table 1, exactly, and the ×1.2 for carriers (§4.6)."""

from __future__ import annotations

import pytest

from pedvr.etiquette.regions import waiting_radii


def test_table_1_radii() -> None:
    assert waiting_radii("single") == (3.3, 2.5, 1.5)  # PullWR, PushWR, AgentWR (m)
    assert waiting_radii("revolving") == (3.0, 3.0, 1.5)
    assert waiting_radii("double") == (3.5, 2.5, 1.5)


def test_a_carrier_waits_further_out_at_a_simple_door_only() -> None:
    assert waiting_radii("single", carrier=True) == pytest.approx((3.96, 3.0, 1.8))
    assert waiting_radii("double", carrier=True) == (3.5, 2.5, 1.5)
    assert waiting_radii("revolving", carrier=True) == (3.0, 3.0, 1.5)
