"""SteerBench scores (SteerSuite's AgentMetricsCollector and composite techniques) on known trajectories."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pedvr.scene.config import SceneConfig
from pedvr.scene.loader import parse_scene
from pedvr.sweep.steerbench import radii_by_id, resample, steerbench_scores

STEERSUITE = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "steersuite"


def _scene(*, obstacles: list[dict[str, object]] | None = None, agents: int = 1) -> SceneConfig:
    return parse_scene(
        {
            "scene": {"name": "bench", "seed": 0, "duration": 5.0},
            "world": {"bounds": [[-10.0, -10.0], [10.0, 10.0]], "obstacles": obstacles or []},
            "agents": {
                "profiles": {"a": {"radius": 0.5, "pref_speed": 1.3, "max_speed": 1.6}},
                "spawns": [
                    {"profile": "a", "state": "s", "positions": [[float(k), 5.0] for k in range(agents)]}
                ],
            },
            "behavior": {"states": {"s": {"goal": {"selector": "stay"}}}},
            "user": {"start": [0.0, -5.0], "enabled": False},
        },
        source="bench.toml",
    )


def _arrays(t: np.ndarray, pos: np.ndarray) -> dict[str, np.ndarray]:
    a = pos.shape[1]
    return {"t": t, "ids": np.arange(a), "is_user": np.zeros(a, bool), "pos": pos}


def test_straight_walk_time_energy_path() -> None:
    dt = 1.0 / 90.0
    t = np.arange(181) * dt  # 2 s at pedvr's step
    pos = np.zeros((181, 1, 2))
    pos[:, 0, 0] = 1.0 * t  # 1 m/s along +x
    s = steerbench_scores(_arrays(t, pos), scene=_scene(), radius=np.array([0.5]))
    # 41 frames at 20 fps, 40 updates of 0.05 s: T = 2 s, E = 40 * 0.5 * 1^2, L = 2 m, no acceleration.
    assert s["time_per_agent_s"] == pytest.approx(2.0)
    assert s["kinetic_energy_per_agent"] == pytest.approx(20.0)
    assert s["path_length_per_agent_m"] == pytest.approx(2.0)
    assert s["acceleration_per_agent"] == pytest.approx(0.0, abs=1e-6)
    assert s["collisions_per_agent"] == 0
    assert s["composite01"] == pytest.approx(22.0) and s["composite02"] == pytest.approx(22.0)


def test_agent_that_leaves_stops_counting_and_speeds_up_counts_acceleration() -> None:
    t = np.arange(21) * 0.05
    pos = np.full((21, 2, 2), np.nan)
    pos[:, 0] = [[0.0, 0.0]]  # stands still for 1 s
    pos[:11, 1, 0] = np.r_[0.0, np.cumsum(np.r_[0.05 * np.ones(5), 0.1 * np.ones(5)])]  # 1 then 2 m/s
    pos[:11, 1, 1] = 3.0
    s = steerbench_scores(_arrays(t, pos), scene=_scene(agents=2), radius=np.array([0.5, 0.5]))
    assert s["agents"] == 2 and s["agents_finished"] == 1
    assert s["time_per_agent_s"] == pytest.approx((1.0 + 0.5) / 2)
    assert s["kinetic_energy_per_agent"] == pytest.approx((5 * 0.5 + 5 * 2.0) / 2)
    # One change of velocity of 1 m/s within a frame: |dv| / frame time = 20, one agent of two.
    assert s["acceleration_per_agent"] == pytest.approx(20.0 / 2)
    assert s["path_length_per_agent_m"] == pytest.approx(0.75 / 2)


def test_unique_collisions_are_episodes_per_object() -> None:
    t = np.arange(8) * 0.05
    pos = np.zeros((8, 3, 2))
    pos[:, 1, 0] = [3.0, 0.9, 0.95, 3.0, 3.0, 0.5, 3.0, 3.0]  # two episodes with agent 0
    pos[:, 2] = [-5.0, 0.0]
    pos[4:, 2] = [-5.6, 0.0]  # the obstacle's face is at x = -6: a 0.1 m penetration from frame 4 on
    box = {"box": [-8.0, -1.0, -6.0, 1.0]}
    s = steerbench_scores(_arrays(t, pos), scene=_scene(obstacles=[box], agents=3), radius=np.full(3, 0.5))
    # agent 0: 2 (with agent 1), agent 1: 2 (with agent 0), agent 2: 1 (with the box) -> 5 / 3.
    assert s["collisions_per_agent"] == pytest.approx(5 / 3, abs=1e-6)
    # Touching within SteerSuite's epsilon (1 mm) is no collision.
    pos[:, 1, 0] = 0.9995
    pos[:, 2] = [-5.0, 0.0]
    s = steerbench_scores(_arrays(t, pos), scene=_scene(obstacles=[box], agents=3), radius=np.full(3, 0.5))
    assert s["collisions_per_agent"] == 0
    # An agent whose centre is inside the obstacle penetrates by more than its radius.
    pos[:, 2] = [-7.0, 0.0]
    s = steerbench_scores(_arrays(t, pos), scene=_scene(obstacles=[box], agents=3), radius=np.full(3, 0.5))
    assert s["collisions_per_agent"] == pytest.approx(1 / 3, abs=1e-6)
    assert s["composite01"] == pytest.approx(50 / 3 + s["time_per_agent_s"] + s["kinetic_energy_per_agent"])


def test_resample_interpolates_and_keeps_absence() -> None:
    t = np.array([0.0, 0.04, 0.08, 0.12])
    pos = np.array([[[0.0, 0.0]], [[0.4, 0.0]], [[0.8, 0.0]], [[np.nan, np.nan]]])
    out = resample(t, pos)
    assert out.shape == (3, 1, 2)
    assert out[1, 0, 0] == pytest.approx(0.5) and np.isnan(out[2, 0, 0])


def test_radii_follow_the_spawn_order() -> None:
    scene = _scene(agents=3)
    assert radii_by_id(scene, 3).tolist() == [0.5, 0.5, 0.5]
    with pytest.raises(ValueError, match="the run has 4 agents but the scene spawns 3"):
        radii_by_id(scene, 4)


@pytest.mark.skipif(
    not (STEERSUITE / "crossing-1.xml").is_file(), reason="../shared/benchmarks/steersuite absent"
)
def test_a_steersuite_case_is_scored(tmp_path: Path) -> None:
    from pedvr.sweep.spec import load_spec
    from pedvr.sweep.task import execute

    spec_path = tmp_path / "ss.toml"
    spec_path.write_text(
        f'[sweep]\nname = "ss"\nscenes = ["{STEERSUITE}/crossing-1.xml"]\nduration = 2.0\nseeds = [3]\n'
    )
    task = load_spec(spec_path).tasks[0]
    result = execute(task)
    assert result["status"] == "ok", result["error"]
    sb = result["metrics"]["steerbench"]
    assert sb["agents"] == result["metrics"]["agents"] == 2
    assert sb["collisions_per_agent"] == 0 and sb["time_per_agent_s"] == pytest.approx(2.0)
    assert sb["composite01"] == pytest.approx(
        50 * sb["collisions_per_agent"] + sb["time_per_agent_s"] + sb["kinetic_energy_per_agent"], abs=1e-5
    )
    assert 1.0 < sb["path_length_per_agent_m"] / 2.0 < 1.7  # walking speed, about 1.3 m/s
