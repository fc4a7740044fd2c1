"""A demonstration as a behavior (PLACE §5–8 on the behavior layer): walking, pointing, gaze,
coordination, re-planning when the user moves, several demonstrators, failures."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from pedvr.demonstrator.arm import CLEARANCE
from pedvr.demonstrator.coordination import TRANSITION
from pedvr.demonstrator.demonstration import Exhibit
from pedvr.errors import SceneError
from pedvr.scene.loader import parse_scene
from pedvr.sim import Simulation
from tests.behavior._scene import scene_text
from tests.demonstrator._demo import TABLE, MovingUser, demo_sim, run_demo

STEP = 0.55  # s: one step of the gait as it stops (locomotion.T_INPLACE), the tolerance of §7's window


def _steps(planted: np.ndarray) -> int:
    """Steps taken: each lift of a foot off the ground."""
    return sum(int(np.count_nonzero(np.diff(planted[:, f].astype(int)) == -1)) for f in range(2))


@pytest.fixture(scope="module", params=[((2.6, 2.4), (-5.0, -3.0)), ((0.0, -3.0), (-4.0, 4.0))],
                ids=["observer_beside", "observer_across"])
def demo(request: pytest.FixtureRequest) -> tuple[object, dict[str, np.ndarray], dict[str, object]]:
    observer, start = request.param
    sim = demo_sim(observer=observer, start=start)
    tr = run_demo(sim).arrays()
    ex = sim.scheduler.objects["vase"]
    assert isinstance(ex, Exhibit)
    return sim, tr, ex.log[0]


def test_the_demonstration_succeeds_and_logs_itself(demo: tuple) -> None:
    sim, _, e = demo
    assert e["outcome"] == "success", e
    assert sim.scheduler.log[-1]["outcome"] == "succeeded"
    assert e["observer"] == "user" and e["replans"] == 0 and e["repositions"] == 0
    assert len(e["t_stroke"]) == 1 and e["t_end"] > e["t_stroke"][0] + 3.0 - 1e-6  # talk = 3 s at the stroke
    s = sim.summary()
    assert s["overlaps_over_1cm"] == 0 and s["affordance_uses"] == {"exhibit.demonstrate": 1}
    assert [x["object"] for x in s["object_log"]] == ["vase"]


def test_arrival_faces_theta(demo: tuple) -> None:
    sim, tr, e = demo
    stop = e["t_feet_stop"][0]
    k = int(np.searchsorted(tr["t"], stop))
    theta = math.radians(e["placements"][0][2])
    err = abs((tr["heading"][k] - theta + math.pi) % (2 * math.pi) - math.pi)
    assert math.degrees(err) < 10.0
    assert math.dist(tr["root"][k], e["placements"][0][:2]) < 0.15


def test_eye_contact_at_the_stroke_point(demo: tuple) -> None:
    _, _, e = demo
    assert e["eye_contact_deg"][0] < 5.0


def test_the_action_starts_before_the_feet_stop(demo: tuple) -> None:
    """§7: the action starts 0.58 s before the locomotion ends (± one step, the swing matching
    and the gait's last step); the feet stop is measured on the body, not taken from the planner."""
    _, tr, e = demo
    ta = e["t_action"][0]
    stepping = tr["stepping"] & (tr["t"] < e["t_stroke"][0] + 1.5)
    feet_stop = float(tr["t"][np.flatnonzero(stepping)[-1]]) + 1.0 / 90.0
    assert ta < feet_stop
    assert abs((feet_stop - ta) - TRANSITION) <= STEP, (feet_stop - ta, e)
    assert e["swing"][0] in ("codirectional", "shortened", "overridden", "nominal")


def test_no_sudden_reversal_of_the_arm(demo: tuple) -> None:
    """From the action's start to the stroke the pointing hand only moves forward relative to the
    body (its walk's backward swing is not carried into the action, §7)."""
    _, tr, e = demo
    t, h, root, hand = tr["t"], tr["heading"], tr["root"], tr["hand"][:, 0]
    fwd = (hand[:, 0] - root[:, 0]) * np.cos(h) + (hand[:, 2] - root[:, 1]) * np.sin(h)
    m = (t >= e["t_action"][0] + 0.05) & (t <= e["t_stroke"][0] - 0.05)
    v = np.gradient(fwd, t)[m]
    assert v.min() > -0.1, v.min()
    assert fwd[m][-1] - fwd[m][0] > 0.2  # the hand went out in front


def test_the_hand_never_enters_an_obstacle(demo: tuple) -> None:
    sim, tr, _ = demo
    stage = sim.scheduler.objects["vase"].stage(sim.scheduler.ctx)
    assert not stage.inside(tr["hand"].reshape(-1, 3)).any()
    # and keeps clear of the table top while pointing over it
    top = tr["hand"][:, :, 1]
    over = stage.inside(np.concatenate([tr["hand"][:, :, :1], np.full(top.shape + (1,), 0.5),
                                        tr["hand"][:, :, 2:]], 2).reshape(-1, 3)).reshape(top.shape)
    assert (top[over] >= 0.75 + CLEARANCE - 0.03).all()


def test_head_rotation_stays_within_phi(demo: tuple) -> None:
    """Appendix A: the head turns at most φ's allowance toward the observer, the eyes do the rest
    (eye contact at the stroke is checked above)."""
    _, tr, e = demo
    t = tr["t"]
    m = (t >= e["t_action"][0]) & (t <= e["t_end"] - 0.1)
    limit = e["head_limit_deg"][0]
    assert np.degrees(np.abs(tr["chain_yaw"][m])).max() <= limit + 1.0


def test_feet_stay_planted_once_stopped(demo: tuple) -> None:
    _, tr, e = demo
    t = tr["t"]
    m = (t >= e["t_feet_stop"][0] + 0.05) & (t <= e["t_end"] - 0.05)
    assert tr["planted"][m].all()
    drift = np.linalg.norm(tr["feet"][m] - tr["feet"][m][:1], axis=2).max()
    assert drift < 0.005


def test_gaze_at_the_observer_is_recorded(demo: tuple) -> None:
    sim, _, e = demo
    ev = [g for g in sim.metrics.gaze_events if g.get("source") == "demonstration"]
    starts = [g["t"] for g in ev if g["event"] == "start"]
    ends = [g["t"] for g in ev if g["event"] == "end"]
    assert starts and len(starts) == len(ends)
    assert all(g["target"] == "user" and g["agent"] == 1 for g in ev)
    # the first gaze at the observer starts before the stroke (negative Δt) and holds through it
    assert starts[0] < e["t_stroke"][0] < ends[0]
    assert sim.summary()["gaze_events"] == sim.metrics.gaze_events


def test_demonstrator_is_left_alone_by_the_user_encounter_model() -> None:
    sim = demo_sim(observer=(0.3, 2.5))
    run = sim.scheduler.start_event("show", {"guide": 1, "observer": 0, "exhibit": "vase"})
    seen = False
    while run.phase != "ended" and sim.t < 30.0:
        sim.step()
        if run.phase == "running":
            seen = True
            assert sim.scheduler.engaged_with_user()[sim.crowd.index_of(1)]
    assert seen and not sim.scheduler.engaged_with_user().any()


def _reposition() -> tuple[Simulation, dict[str, np.ndarray], dict[str, object]]:
    user = MovingUser((0.3, 2.5), (2.0, 2.0), at=11.0, heading=-math.pi / 2)
    sim = demo_sim(observer=(0.3, 2.5), user=user, talk=10.0)
    tr = run_demo(sim, seconds=40.0).arrays()
    return sim, tr, sim.scheduler.objects["vase"].log[0]


def test_a_large_move_of_the_user_triggers_a_replan_and_a_short_reposition() -> None:
    _, tr, e = _reposition()
    assert e["outcome"] == "success", e
    assert e["replans"] >= 1 and e["repositions"] == 1
    assert len(e["t_stroke"]) == 2 and max(e["eye_contact_deg"]) < 5.0
    assert math.dist(e["placements"][0][:2], e["placements"][1][:2]) < 1.2
    # side or back steps facing between the old and the new orientation: no turn to walk and back
    t = tr["t"]
    m = (t > e["t_feet_stop"][0] + 1.0) & (t <= e["t_feet_stop"][1])
    h = np.degrees(tr["heading"][m])
    lo, hi = sorted((e["placements"][0][2], e["placements"][1][2]))
    assert lo - 10.0 <= h.min() and h.max() <= hi + 10.0, (h.min(), h.max(), lo, hi)
    # never within DWELL of arriving, and the talk went on for what was left (10 s in all)
    held = (e["t_stroke"][1] - e["t_stroke"][0]) + (e["t_end"] - e["t_stroke"][1])
    assert held > 10.0


def test_a_short_reposition_takes_two_to_four_steps() -> None:
    """§5: short-range repositioning in 2-4 steps, no turning around."""
    _, tr, e = _reposition()
    t = tr["t"]
    m = (t > e["t_feet_stop"][0] + 1.0) & (t <= e["t_feet_stop"][1])
    assert 2 <= _steps(tr["planted"][m]) <= 4


def test_a_small_move_of_the_user_triggers_no_replan() -> None:
    user = MovingUser((0.3, 2.5), (0.6, 2.4), at=11.0, heading=-math.pi / 2)
    sim = demo_sim(observer=(0.3, 2.5), user=user, talk=8.0)
    run_demo(sim, seconds=40.0)
    e = sim.scheduler.objects["vase"].log[0]
    assert e["outcome"] == "success"
    assert e["replans"] == 0 and e["repositions"] == 0 and len(e["placements"]) == 1


def test_same_seed_same_demonstration() -> None:
    def once() -> tuple[bytes, list]:
        sim = demo_sim(observer=(2.6, 2.4), user=MovingUser((2.6, 2.4), (-1.5, 2.0), at=9.0, heading=0.0),
                       talk=6.0)
        run_demo(sim)
        rec = sim.recording.arrays()  # type: ignore[union-attr]
        return rec["pos"].tobytes() + rec["heading"].tobytes(), sim.scheduler.objects["vase"].log

    a, b = once(), once()
    assert a[0] == b[0] and a[1] == b[1]


def test_two_demonstrators_at_once_keep_apart() -> None:
    extra = """
[[behavior.objects]]
name = "bowl"
kind = "exhibit"
at = [-0.4, 0.1]
talk = 3.0
"""
    sim = demo_sim(observer=(0.0, 2.6), extra=extra, agents=[(-5.0, -3.0, "stand"), (5.0, -3.0, "stand")])
    a = sim.scheduler.start_event("show", {"guide": 1, "observer": 0, "exhibit": "vase"})
    b = sim.scheduler.start_event("show", {"guide": 2, "observer": 0, "exhibit": "bowl"})
    while (a.phase != "ended" or b.phase != "ended") and sim.t < 40.0:
        sim.step()
    log = {e["object"]: e for o in sim.scheduler.objects.values() for e in o.log}
    assert log["vase"]["outcome"] == "success" and log["bowl"]["outcome"] == "success", log
    pa, pb = log["vase"]["placements"][-1], log["bowl"]["placements"][-1]
    assert math.dist(pa[:2], pb[:2]) >= 0.5 + 0.1
    assert sim.summary()["overlaps_over_1cm"] == 0


def test_no_placement_fails_with_its_reason() -> None:
    walls = TABLE + "".join(f"""
[[world.obstacles]]
wall = {w}
height = 2.5
""" for w in ([[2.0, 2.0], [3.6, 2.0]], [[2.0, 3.6], [3.6, 3.6]], [[2.0, 2.0], [2.0, 3.6]], [[3.6, 2.0], [3.6, 3.6]]))
    sim = demo_sim(observer=(2.8, 2.8), world=walls)
    run = sim.scheduler.start_event("show", {"guide": 1, "observer": 0, "exhibit": "vase"})
    while run.phase != "ended" and sim.t < 5.0:
        sim.step()
    assert sim.scheduler.log[-1]["outcome"] == "failed"
    assert sim.scheduler.objects["vase"].failures == {"no placement": 1}
    assert sim.scheduler.objects["vase"].log[0]["why"] == "no placement"


def test_a_bfsm_state_runs_a_demonstration_to_the_user() -> None:
    behavior = """
[[behavior.objects]]
name = "vase"
kind = "exhibit"
at = [0.3, 0.2]
talk = 2.0

[behavior.trees.show_vase]
params = { self = "agent" }
root = { demonstrate = "self", object = "vase", to = "user" }

[behavior.states.guide]
goal = { selector = "stay" }
tree = "show_vase"

[[behavior.states.guide.transitions]]
on = "success"
to = "stand"
"""
    text = scene_text(agents=[(-4.0, -3.0, "guide")], behavior=behavior, world=TABLE, user_start=(0.3, 2.5))
    sim = Simulation(parse_scene(tomllib.loads(text), source="g.toml"))
    while sim.t < 25.0 and not sim.scheduler.objects["vase"].log:
        sim.step()
    e = sim.scheduler.objects["vase"].log[0]
    assert e["outcome"] == "success" and e["observer"] == "user"
    sim.advance_to(sim.t + 0.1)  # the state's success transition at the next decision
    assert sim.bfsm.names[sim.behavior.state[sim.crowd.index_of(1)]] == "stand"


@pytest.mark.parametrize(("snippet", "line"), [
    ('[[behavior.objects]]\nname = "v"\nkind = "exhibit"\nat = [0.0, 0.0]\naction = "wave"\n',
     "s.toml: behavior.objects[0].action = 'wave': expected one of point, touch"),
    ('[[behavior.objects]]\nname = "v"\nkind = "exhibit"\nat = [0.0, 0.0]\ntalk = -1\n',
     "s.toml: behavior.objects[0].talk = -1: must be a number > 0"),
    ('[[behavior.objects]]\nname = "c"\nkind = "chair"\nat = [0.3, 0.2]\n',
     "s.toml: behavior.objects[0].at = [0.3, 0.2]: lies outside the walkable area"),
    ('[[behavior.objects]]\nname = "c"\nkind = "chair"\nat = [3.0, 3.0]\n'
     '[behavior.trees.t]\nparams = { a = "agent" }\nroot = { demonstrate = "a", object = "c" }\n',
     "s.toml: behavior.trees.t.root.object = 'c': a chair has no affordance 'demonstrate'; kinds that have it: "
     "exhibit"),
])
def test_scene_problems_name_the_key(snippet: str, line: str) -> None:
    text = scene_text(agents=[(-4.0, -3.0, "stand")], behavior=snippet, world=TABLE)
    with pytest.raises(SceneError) as err:
        parse_scene(tomllib.loads(text), source="s.toml")
    assert line in err.value.problems, err.value.problems


def test_a_demonstration_ends_when_the_observer_walks_away() -> None:
    user = MovingUser((0.3, 2.5), (7.5, -4.0), at=9.0, heading=0.0)  # 8.3 m from the vase: gone
    sim = demo_sim(observer=(0.3, 2.5), user=user, talk=20.0)
    run_demo(sim, seconds=40.0)
    e = sim.scheduler.objects["vase"].log[0]
    assert e["outcome"] == "left" and e["why"] == "observer left"
    assert sim.scheduler.log[-1]["outcome"] == "succeeded"  # the event ends normally ...
    assert sim.scheduler.objects["vase"].uses == {}  # ... but it was no whole demonstration
    ends = [x for x in sim.scheduler.ctx.events if x["event"] == "end"]
    assert [x["outcome"] for x in ends] == ["left"]


def test_the_sofa_host_shows_three_objects_to_the_seated_guest() -> None:
    """The paper's sofa scene: the observer is an agent sitting on the sofa (its eyes at seated height)."""
    from pedvr.scene.loader import load_scene
    from pedvr.scenes import resolve_scene

    sim = Simulation(load_scene(resolve_scene("place_sofa")))
    sim.advance_to(55.0)
    log = {e["object"]: e for o in sim.scheduler.objects.values() for e in o.log}
    assert [log[k]["outcome"] for k in ("fax", "radio", "vase")] == ["success"] * 3, log
    assert all(log[k]["observer"] == 2 and max(log[k]["eye_contact_deg"]) < 5.0 for k in log)
    assert sim.scheduler.objects["seat_left"].occupant == 2 or sim.scheduler.objects["seat_right"].occupant == 2
    gaze = [g for g in sim.metrics.gaze_events if g.get("source") == "demonstration"]
    assert gaze and {g["target"] for g in gaze} == {"agent"}
