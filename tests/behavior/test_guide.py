"""The worked example in pedvr.behavior's docstring runs as written: a gate held for the user."""

from __future__ import annotations

import textwrap
from collections.abc import Iterator

import pytest

import pedvr.behavior
from pedvr.behavior.library import trees
from pedvr.behavior.nodes import node_types
from pedvr.behavior.objects import object_kinds
from tests.behavior._scene import make_sim, step_until


def _blocks() -> list[str]:
    """The ``::`` literal blocks of the guide, dedented."""
    doc = pedvr.behavior.__doc__ or ""
    guide = doc[doc.index("Worked example"):]
    out = []
    for part in guide.split("::\n\n")[1:]:
        lines = []
        for line in part.splitlines():
            if line and not line.startswith("    "):
                break
            lines.append(line)
        out.append(textwrap.dedent("\n".join(lines)))
    return out


@pytest.fixture
def guide() -> Iterator[dict[str, object]]:
    code, _ = _blocks()
    names: dict[str, object] = {}
    try:
        exec(compile(code, "pedvr.behavior guide", "exec"), names)  # noqa: S102 - the doc's own example
        yield names
    finally:  # the example registers into process-wide registries: take it out again
        object_kinds._entries.pop("gate", None)
        node_types._entries.pop("through", None)
        trees._entries.pop("hold_gate", None)


def test_the_gate_example_holds_the_gate_for_the_user(guide: dict[str, object]) -> None:
    _, toml = _blocks()
    walls = '[[world.obstacles]]\nkind = "wall"\nwall = [[0.0, 0.8], [0.0, 6.0]]\n' \
            '[[world.obstacles]]\nkind = "wall"\nwall = [[0.0, -0.8], [0.0, -6.0]]\n'
    # The user strolls round by the south and through the gate; the agent stands near it.
    sim = make_sim(agents=[(-1.0, 1.2, "stand")], world=walls, behavior=toml, user_start=(-6.0, -5.0),
                   user_route=[(-1.5, -4.0), (-1.5, 0.0), (5.0, 0.0)], user_speed=0.7)
    gate = sim.scheduler.objects["gate_1"]
    held_while_user_before = False

    def check() -> bool:
        nonlocal held_while_user_before
        if gate.holder == 1 and sim.crowd.pos[0, 0] < -0.5:  # type: ignore[attr-defined]
            held_while_user_before = True
        return bool(sim.scheduler.log)

    assert step_until(sim, check, seconds=25.0)
    ev = sim.scheduler.log[0]
    assert ev["event"] == "hold_gate" and ev["outcome"] == "succeeded"
    assert held_while_user_before
    assert sim.crowd.pos[0, 0] > 0.5 and sim.crowd.pos[sim.crowd.index_of(1), 0] > 0.5  # both through
    assert gate.holder is None  # type: ignore[attr-defined]
    sim.advance_to(sim.t + 5.0)
    assert len(sim.scheduler.log) == 1  # the trigger's cooldown: once
