"""Stage 3 on floors unlike the maze, end to end (the real host daemon against the twin over
ptys): an 8 m corridor started at one end, far from the map's centre, and two rooms whose only
doorway a dropped cylinder closes."""

from __future__ import annotations

from pathlib import Path

from jackson.experiments.stage3 import NavTrialSpec, mapping_spec, run_nav_trial, world_goals
from jackson.experiments.worlds_campaign import health_events
from jackson.sim.config import load_world


def test_a_corridor_started_at_one_end_is_mapped_and_driven_to_its_far_end(
    tmp_path: Path,
) -> None:
    world = load_world("corridor_8m")
    start_x, goal = world.start_pose[0], world_goals(world)[0]
    assert goal.x - start_x > 6.5  # the local window's first move is more than its 3 m size
    m = run_nav_trial(mapping_spec("jackson_physical", "corridor_8m", 5, tmp_path / "map"))
    assert m["completed"], m["failure"]
    assert m["map_ssim"] > 0.8
    r = run_nav_trial(
        NavTrialSpec(
            0, 6, "jackson", "corridor_8m", tmp_path / "nav",
            map_yaml=tmp_path / "map" / "built_map.yaml", goals=(goal,),
        )
    )  # fmt: skip
    assert r["completed"], r["failure"]
    assert r["goal_error_m"] <= 0.25  # the twin's ground truth
    assert r["collisions"] == 0 and r["d_min_m"] > 0.0 and r["t_insert_s"] > 0.0
    exclusions, _, events = health_events(tmp_path / "nav", r["sim_s"])
    assert exclusions == 0, events


def test_a_goal_behind_a_closed_doorway_is_reported_unreachable_and_the_robot_stops(
    tmp_path: Path,
) -> None:
    m = run_nav_trial(mapping_spec("jackson_physical", "blocked_route", 7, tmp_path / "map"))
    assert m["completed"], m["failure"]
    r = run_nav_trial(
        NavTrialSpec(
            0, 8, "jackson_physical", "blocked_route", tmp_path / "nav",
            map_yaml=tmp_path / "map" / "built_map.yaml",
            goals=world_goals(load_world("blocked_route")),
        )
    )  # fmt: skip
    assert not r["completed"]
    assert r["failure"].startswith("goal (2.20, -0.30) unreachable: blocked at (")
    assert r["t_insert_s"] > 0.0 and r["sim_s"] - r["t_insert_s"] <= 15.0
    assert r["recoveries"] == 0 and r["collisions"] == 0
    assert r["d_min_m"] > 0.3  # it stopped well short of the cylinder in the doorway
