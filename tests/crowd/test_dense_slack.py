"""Issue 26: in ORCA's dense case a coupled agent keeps toward its goal within ``[steering]
dense_slack`` of the least violation (pedvr.crowd.orca.toward_preferred), where the paper's
§5.3 velocity ignores the goal; decoupled stays the paper's plain ORCA."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pedvr.crowd import orca
from pedvr.crowd.steering import Steering, SteeringInputError
from pedvr.scene.config import SteeringParams
from pedvr.scene.loader import load_any
from pedvr.sim import Simulation
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd

DT = 1 / 90
SLACK = 0.1  # m/s: the value measured in issue 26's benchmark


def test_among_the_least_violating_velocities_the_one_nearest_the_goal() -> None:
    # three agent lines no velocity meets: y >= 0.1, y <= -0.1, x <= 0 (the left of each direction)
    lines = np.array([[0.0, 0.1, 1.0, 0.0], [0.0, -0.1, -1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    fail, x, y = orca.linear_program2(lines, 3, 1.5, 1.0, 0.0, False)
    assert fail < 3
    rx, ry = orca.linear_program3(lines, 3, 0, fail, 1.5, x, y, np.zeros((3, 4)))
    worst = max(orca._det(ln[2], ln[3], ln[0] - rx, ln[1] - ry) for ln in lines)
    assert worst == pytest.approx(0.1)  # the paper's dense velocity: 0.1 m/s into two lines
    # lines 0-2 are neighbours 0-2's, 1 m ahead (+x) of the agent at the origin and going +x: the
    # agent would push them the way they go, so every line gets the slack
    nbrs, ahead, at = np.arange(3), np.tile([1.3, 0.0], (3, 1)), np.tile([1.0, 0.0], (3, 1))
    tx, ty = orca.toward_preferred(lines.copy(), 3, 0, 1.5, 1.0, 0.0, rx, ry, 0.25, nbrs, ahead, at, 0.0, 0.0)
    np.testing.assert_allclose((tx, ty), (0.35, 0.0), atol=1e-9)  # x <= 0 moved back by 0.1 + 0.25
    assert math.hypot(tx - 1.0, ty) < math.hypot(rx - 1.0, ry) - 0.2
    # the hard lines stay hard: with x <= 0.2 hard, the slack cannot take it past 0.2
    hard = np.vstack([[[0.2, 0.0, 0.0, 1.0]], lines])
    tx, ty = orca.toward_preferred(hard, 4, 1, 1.5, 1.0, 0.0, rx, ry, 0.25, nbrs, ahead, at, 0.0, 0.0)
    assert tx == pytest.approx(0.2) and abs(ty) <= 0.35 + 1e-9


def _boxed(params: SteeringParams, *, coupled: bool, same_way: bool = False) -> np.ndarray:
    """Agent 0 walks +x at 0.3 m/s and wants 1.3; three neighbours close in on it from ahead and
    from either side: ORCA's dense case. Each wants to walk at agent 0 (oncoming, crossing) or,
    ``same_way``, +x as it does (a crowd before an opening: they move in as the crowd shifts).
    Agent 0's new velocity."""
    pos = [(0.0, 0.0), (0.47, 0.1), (0.1, 0.47), (-0.1, -0.47)]
    if same_way:
        pref = [(1.3, 0.0)] * 4
    else:
        pref = [(1.3, 0.0)] + [tuple(-1.3 * np.array(p) / math.hypot(*p)) for p in pos[1:]]
    state = crowd(pos, [(0.3, 0.0), (-0.4, 0.0), (0.0, -0.4), (0.0, 0.4)], pref,
                  heading=[0.0] + [math.atan2(-p[1], -p[0]) for p in pos[1:]])
    s = Steering(params, ObstacleSet.empty(), coupled=coupled)
    v = s.compute_velocities(state, DT)
    assert s.last_status[0] & orca.STATUS_DENSE
    return v[0]


def test_a_boxed_in_coupled_agent_keeps_toward_its_goal_decoupled_does_not_change() -> None:
    assert SteeringParams().dense_slack == SLACK  # on by default (see SteeringParams.dense_slack)
    off = dataclasses.replace(SteeringParams(), dense_slack=0.0)
    on = dataclasses.replace(SteeringParams(), dense_slack=SLACK)
    v_off, v_on = _boxed(off, coupled=True, same_way=True), _boxed(on, coupled=True, same_way=True)
    assert v_off[0] < 0.3 - 0.02  # the paper's least violation brakes it (2.5 m/s² a step)
    assert v_on[0] > 0.3 + 0.01  # with the slack it speeds up toward its goal (1.5 m/s² a step)
    np.testing.assert_array_equal(_boxed(off, coupled=False, same_way=True),
                                  _boxed(on, coupled=False, same_way=True))


def test_no_slack_against_people_coming_the_other_way() -> None:
    """The slack presses only on neighbours going the agent's way (toward_preferred): boxed in
    by people walking at it, a coupled agent takes the paper's least violation with or without
    it (pressing on them shoved walkers backwards past their limits in shibuya_crossing)."""
    off = dataclasses.replace(SteeringParams(), dense_slack=0.0)
    on = dataclasses.replace(SteeringParams(), dense_slack=SLACK)
    np.testing.assert_array_equal(_boxed(off, coupled=True), _boxed(on, coupled=True))


def test_a_negative_slack_is_refused() -> None:
    with pytest.raises(SteeringInputError, match=r"dense_slack = -1.0: must be >= 0 m/s"):
        Steering(dataclasses.replace(SteeringParams(), dense_slack=-1.0), ObstacleSet.empty(), coupled=True)


def _out_by(steering: SteeringParams, until: float, *, seed: int = 1, case: str = "uo_070") -> tuple[int, dict]:
    scene = dataclasses.replace(load_any(f"scenes/validation/{case}.toml", seed=seed), steering=steering)
    sim = Simulation(scene, seed=seed, condition="pedvr")
    sim.advance_to(until)
    s = sim.summary()
    return int(s["sink_agents_removed"]), s


OPENING_SEEDS = (1, 2, 3, 4)


@pytest.fixture(scope="module")
def out_of_uo_070() -> dict[str, list[tuple[int, dict]]]:
    """People out of uo_070's corridor after 60 s, seeds 1-4: the defaults and no dense slack
    (each with the run's summary)."""
    variants = {"default": SteeringParams(),
                "no_slack": dataclasses.replace(SteeringParams(), dense_slack=0.0)}
    return {k: [_out_by(v, 60.0, seed=seed) for seed in OPENING_SEEDS] for k, v in variants.items()}


@pytest.fixture(scope="module")
def out_of_bottleneck_050() -> dict[str, list[tuple[int, dict]]]:
    """People out of the 0.5 m bottleneck's room after 40 s, seeds 1-4: the defaults, and coupled
    agents seeing obstacles 1 s ahead instead of 0.5 s."""
    variants = {"default": SteeringParams(),
                "horizon_1s": dataclasses.replace(SteeringParams(), time_horizon_obst_coupled=1.0)}
    return {k: [_out_by(v, 40.0, seed=seed, case="bottleneck_050") for seed in OPENING_SEEDS]
            for k, v in variants.items()}


def test_a_crowd_at_an_opening_flows_faster(out_of_uo_070: dict[str, list[tuple[int, dict]]]) -> None:
    """111 people through the Jülich corridor's 0.7 m entrance (scenes/validation/uo_070): more are
    out of the corridor after 60 s with the slack than with the paper's least violation, and no
    body overlaps another. Seed 1 alone gave 68 against 52 until stop 36's headway change (of two
    each ahead of the other, only the one further behind keeps its time gap), which freed part of
    the same jam. On stop 40's code, seeds 1-4: 273 against 218 (71 / 67 / 70 / 65 against 49 /
    63 / 56 / 50); seeds 1-16: 1049 against 865, every seed the same way. (Until the acceleration
    limit rose to 2.2 m/s² this was 60 people at the 0.8 m bottleneck after 30 s, 33 against 18;
    there the two now come out within a few people of each other, seeds 1-3.)"""
    assert SteeringParams().dense_slack == SLACK
    new = sum(n for n, _ in out_of_uo_070["default"])
    old = sum(n for n, _ in out_of_uo_070["no_slack"])
    assert new >= old + 20, (new, old)
    assert all(s["overlaps_over_1cm"] == 0 for _, s in out_of_uo_070["default"])


def test_a_shorter_obstacle_horizon_opens_the_bottleneck(
        out_of_bottleneck_050: dict[str, list[tuple[int, dict]]]) -> None:
    """Coupled agents outside a door's etiquette see obstacles ``time_horizon_obst_coupled``
    (0.5 s) ahead: with 1 s people slow at the edges of an opening a second before they reach
    them. Out of the 0.5 m bottleneck's room after 40 s, seeds 1-4 together: 171 against 138 with
    1 s (43 / 44 / 41 / 43 against 32 / 33 / 37 / 36; seeds 5-8 174 against 145, every seed of
    the eight the same way). Until stop 41 this was measured at uo_070's 0.7 m entrance after
    60 s, seeds 1-4 (273 against 251 on stop 40's code); over seeds 1-16 the two horizons pass
    the same number there (1049 against 1040, seven seeds each way): that test passed on its
    seeds' luck, and a change of the gait's last bits turned it (265 against 269). At the 0.8 m
    bottleneck after 30 s, seeds 1-8: 292 against 278. Nobody overlaps a wall or another body."""
    assert SteeringParams().time_horizon_obst_coupled == 0.5 and SteeringParams().time_horizon_obst == 1.0
    short = sum(n for n, _ in out_of_bottleneck_050["default"])
    long = sum(n for n, _ in out_of_bottleneck_050["horizon_1s"])
    assert all(s["overlaps_over_1cm"] == 0 and s["wall_overlap_max_m"] < 0.01
               for _, s in out_of_bottleneck_050["default"])
    assert short >= long + 15, (short, long)


def test_no_slack_for_those_in_a_door_s_etiquette() -> None:
    """At a busy single door the etiquette orders who goes: those taking part in it (approaching
    included, ``DoorEtiquette.at_doors``) take the paper's least violation and see obstacles
    ``time_horizon_obst`` ahead, as with the slack off and the longer horizon for everyone, where
    the slack and the shorter horizon would have moved some of them."""
    sim = Simulation(load_any("scenes/validation/door_single_flow.toml", seed=1), seed=1, condition="pedvr")
    steer = sim.steering
    assert steer.dense_slack == SLACK
    mattered = 0
    while sim.t < 60.0:
        sim.advance_to(sim.t + 0.25)
        at = sim.etiquette.at_doors(sim.crowd)
        spared = steer.compute_velocities(sim.crowd, sim.dt, at_doors=at)
        everyone = steer.compute_velocities(sim.crowd, sim.dt)
        steer.dense_slack, steer.short_obst = 0.0, steer.params.time_horizon_obst
        try:
            off = steer.compute_velocities(sim.crowd, sim.dt)
        finally:
            steer.dense_slack, steer.short_obst = SLACK, steer.params.time_horizon_obst_coupled
        np.testing.assert_array_equal(spared[at], off[at])
        mattered += int(np.count_nonzero(np.abs(everyone[at] - off[at]).max(axis=1, initial=0.0) > 0.0))
    assert mattered > 0
