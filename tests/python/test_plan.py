"""quadhand.plan(): the plan of a task equals quadhand-plan's (report numbers
and plan file), whichever way the task, robot and scene are given."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import quadhand
from conftest import BIN_DIR, PYTHON_DIR, ROOT, SCENE, URDF

# Wall times differ between runs; every other number of the report must not.
TIMING_KEYS = {"solve_ms", "front_end_ms", "front_end_build_ms", "post_check_ms", "representation_build_ms", "scene_load_ms", "robot_load_ms", "sdf_load_ms", "total_ms", "seconds"}


def without_timings(value):
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def window_cup_dict():
    """data/tasks/window_cup.yaml as a dict, without robot, SDF and scene keys."""
    return {
        "start": {"position": [0.5, 0.2, 1.2], "velocity": [0, 0, 0], "acceleration": [0, 0, 0],
                  "yaw": 3.14159265, "joints": np.array([0.3, -0.2, 0.0])},
        "goal": {
            "position": [-2.994932877, 0.0, 1.287928495],
            "yaw": 3.14159265,
            "joints": [0.6, 0.9707963268, 0.0],
            "tool": {"position": [-3.2, 0.0, 0.86], "orientation": [0.0, -0.7071067812, 0.0, 0.7071067812],
                     "insertion": {"direction": [0, 0, -1], "length": 0.10}},
        },
        "limits": {"v_max": 2.0, "a_max": 4.0, "yaw_rate_max": 1.5, "body_rate_xy_max": 3.0},
        "safety_distance": 0.03,
    }


def plan_file_with_cli(task, sdf_dir, tmp_path):
    """quadhand-plan on `task` (a dict) written as a file with the robot, SDF
    and scene paths: its plan file's text and its report."""
    task_file = tmp_path / "task.json"  # JSON is YAML
    task_file.write_text(json.dumps(dict(task, robot=str(URDF), sdf_dir=str(sdf_dir), scene=str(SCENE)),
                                    default=lambda array: array.tolist()))
    csv, report = tmp_path / "plan.csv", tmp_path / "report.json"
    run = subprocess.run([str(BIN_DIR / "quadhand-plan"), str(task_file), "--out", str(csv), "--report", str(report)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return csv.read_text(), json.loads(report.read_text())


def read_csv(path):
    lines = path.read_text().splitlines()
    return lines[0].split(","), np.array([[float(v) for v in line.split(",")] for line in lines[1:]])


@pytest.fixture(scope="module")
def cli_plan(task_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli")
    csv, report = out / "plan.csv", out / "report.json"
    run = subprocess.run([str(BIN_DIR / "quadhand-plan"), str(task_file), "--out", str(csv), "--report", str(report)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return csv, json.loads(report.read_text())


@pytest.fixture(scope="module")
def python_plan(task_file):
    return quadhand.plan(str(task_file))


def test_plan_from_a_task_file_equals_the_cli(cli_plan, python_plan):
    csv, cli_report = cli_plan
    assert python_plan.success and python_plan.status == "success"
    assert without_timings(python_plan.report) == without_timings(cli_report)
    assert python_plan.csv() == csv.read_text()
    columns, values = read_csv(csv)
    assert python_plan.columns == columns
    assert python_plan.table.shape == values.shape
    # The table holds full doubles; the file ten significant digits.
    assert np.all(np.abs(python_plan.table - values) <= 1e-9 * np.maximum(1.0, np.abs(values)))
    for i, name in enumerate(columns):
        assert np.array_equal(python_plan.trajectory[name], python_plan.table[:, i])


def test_plan_with_robot_scene_and_dict_equals_the_file(python_plan, sdf_dir):
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    scene = quadhand.Scene.from_pcd(SCENE)
    points = np.array(scene.points)  # a plain array, as a user's own cloud would be
    result = quadhand.plan(window_cup_dict(), robot=robot, scene=points)
    assert result.success
    expected = without_timings(python_plan.report)
    got = without_timings(result.report)
    expected.pop("task"), got.pop("task")
    assert got == expected
    assert result.csv() == python_plan.csv()


def test_a_scene_is_shared_between_plans_without_copies(sdf_dir):
    scene = quadhand.Scene.from_pcd(SCENE)
    view = scene.points
    assert view.shape == (len(scene), 3) and not view.flags.writeable
    assert np.shares_memory(view, scene.points)  # a view of the scene's own copy, every time
    with pytest.raises(ValueError):
        view[0, 0] = 1.0
    assert scene.dropped_non_finite == 0 and scene.source == str(SCENE)


def test_every_solver_and_representation_plans_or_says_why(task_file):
    assert "lbfgs" in quadhand.solver_names()
    assert quadhand.representation_names() == ["mrc_sdf", "esdf", "sfc"]
    result = quadhand.plan(str(task_file), solver="nlopt")
    assert result.success, result.message
    assert result.report["solver"] == "nlopt"


def test_a_failed_plan_returns_no_trajectory_unless_asked(sdf_dir):
    # A body-rate limit no flight through the windows can keep: planning runs, the post-check fails.
    task = window_cup_dict()
    task["limits"]["body_rate_xy_max"] = 0.05
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    scene = quadhand.Scene.from_pcd(SCENE)
    result = quadhand.plan(task, robot=robot, scene=scene)
    assert not result.success and result.status == "post_check_failed"
    assert result.message.startswith("body_rate_xy")
    assert result.table is None and result.trajectory is None
    assert [c["name"] for c in result.report["checks"] if not c["passed"]] == ["body_rate_xy"]
    with pytest.raises(quadhand.Error):
        result.csv()
    kept = quadhand.plan(task, robot=robot, scene=scene, keep_failed_plan=True)
    assert not kept.success
    assert kept.table.shape[1] == len(kept.columns) and kept.trajectory["t"][-1] == kept.report["duration_s"]


def test_generated_sdfs_are_one_file_per_collision_link(sdf_dir):
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    written = sorted(p.name for p in sdf_dir.iterdir())
    assert written == sorted(f"{name}.qhsdf" for name in robot.collision_link_names)
    assert robot.joint_names == ["joint1", "joint2", "joint3"]
    assert robot.sdf_dir == str(sdf_dir)


def test_exact_clearance_against_single_points(sdf_dir):
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    position, joints = [0.0, 0.0, 1.0], [0.3, -0.2, 0.0]
    far = quadhand.exact_clearance(robot, np.array([[10.0, 10.0, 10.0]]), position, joints, reach=0.5)
    assert far == (0.5, "")
    inside = quadhand.exact_clearance(robot, np.array([position]), position, joints)
    assert inside[0] < 0 and inside[1] == "base_link"
    # Straight above the base (robot.md): the plate's top face is at z = 0.025
    # and the rotor guards' top disks (r = 0.065, centres 0.165 m off the axis)
    # at z = 0.035; the guards' circles are tessellated within 0.1 mm.
    clearance = quadhand.ExactClearance
    for h in (0.05, 0.3, 0.6):
        expected = min(h - 0.025, math.hypot(0.165 - 0.065, h - 0.035))
        d, link = clearance(robot, np.array([[0.0, 0.0, 1.0 + h]])).query(position, joints, yaw=0.0)
        assert link == "base_link" and math.isclose(d, expected, abs_tol=2e-4 if h > 0.5 else 1e-6), (h, d)
    # Turning the base about the vertical axis does not move a point on that axis.
    d_turned = clearance(robot, np.array([[0.0, 0.0, 1.3]])).query(position, joints, yaw=1.0)[0]
    assert math.isclose(d_turned, 0.275, abs_tol=1e-6)
    # Upside down (attitude: half turn about x) the point above faces the arm side; still a real distance.
    d_flipped = clearance(robot, np.array([[0.0, 0.0, 1.3]])).query(position, joints, attitude=[0, 1, 0, 0])[0]
    assert 0 < d_flipped < 0.3


def test_the_python_example_runs(sdf_dir):
    env = dict(os.environ, PYTHONPATH=PYTHON_DIR)
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "plan_window_cup.py"), str(sdf_dir)],
                         capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith("success: plan passed the post-check")
    assert "final state:" in run.stdout


def test_a_configuration_changes_the_plan_and_is_recorded(task_file, python_plan, cli_plan, tmp_path):
    assert python_plan.report["planner_config"]["source"] == "defaults"
    assert cli_plan[1]["planner_config"] == python_plan.report["planner_config"]
    values = python_plan.report["planner_config"]["values"]
    assert values["cost"]["samples_per_piece"] == 16 and values["plan"]["stow_joints_in_transit"] is True

    config = {"cost": {"samples_per_piece": 12}, "solver": {"max_iterations": 60}}
    result = quadhand.plan(str(task_file), config=config)
    recorded = result.report["planner_config"]
    assert recorded["source"] == "config"
    assert recorded["values"]["cost"]["samples_per_piece"] == 12
    assert recorded["values"]["solver"]["max_iterations"] == 60
    assert result.report["iterations"] <= 60 * len(result.report["attempts"])

    path = tmp_path / "planner.yaml"
    path.write_text("cost:\n  samples_per_piece: 12\nsolver:\n  max_iterations: 60\n")
    csv, report = tmp_path / "p.csv", tmp_path / "r.json"
    run = subprocess.run([str(BIN_DIR / "quadhand-plan"), str(task_file), "--planner-config", str(path), "--out",
                          str(csv), "--report", str(report)], capture_output=True, text=True)
    assert run.returncode in (0, 1), run.stderr
    cli_report = json.loads(report.read_text())
    assert cli_report["planner_config"]["source"] == str(path)
    cli_report["planner_config"]["source"] = "config"
    assert without_timings(cli_report) == without_timings(dict(result.report, task=str(task_file)))

    with pytest.raises(quadhand.Error, match=r"^config: cost.samples: unknown key"):
        quadhand.plan(str(task_file), config={"cost": {"samples": 12}})


def test_a_coarse_voxel_leaf_is_a_caution_and_a_warning(python_plan, sdf_dir):
    assert python_plan.cautions == []
    task = window_cup_dict()
    task["scene"] = [{"file": str(SCENE), "voxel": 0.05}]
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    with pytest.warns(UserWarning, match="voxel leaf 0.05 m is coarser than safety_distance 0.03 m"):
        result = quadhand.plan(task, robot=robot)
    assert len(result.cautions) == 1 and "scene[0]" in result.cautions[0]
    assert result.report["checked_points"] > result.report["scene_points"]


def test_a_mission_dict_plans_as_the_cli_plans_its_file(sdf_dir, tmp_path):
    """A mission (grasp the cup, lift it) from a dict: the same plan, step
    and gripper columns and per-step report as quadhand-plan's."""
    mission = window_cup_dict()
    goal = mission.pop("goal")
    mission["mission"] = [
        {"reach": goal},
        {"grasp": {"object": {"shape": {"cylinder": {"radius": 0.04, "length": 0.10}},
                              "pose": {"position": [-3.2, 0.0, 0.85], "orientation": [1, 0, 0, 0]},
                              "mass": 0.08}}},
        {"move": {"length": 0.15}},
    ]
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    result = quadhand.plan(mission, robot=robot, scene=quadhand.Scene.from_pcd(SCENE))
    assert result.success, result.message
    assert [s["kind"] for s in result.report["steps"]] == ["reach", "grasp", "move"]
    assert all(s["certified"] for s in result.report["steps"])
    assert result.report["steps"][0]["held_object_min_clearance_m"] is None
    assert result.report["steps"][2]["held_object_min_clearance_m"] >= 0.0
    assert result.columns[-2:] == ["step", "gripper"]
    assert set(result.trajectory["step"]) == {0.0, 1.0, 2.0}
    assert np.array_equal(result.trajectory["gripper"], (result.trajectory["step"] >= 1).astype(float))

    csv, report = plan_file_with_cli(mission, sdf_dir, tmp_path)
    assert result.csv() == csv
    cli = without_timings(report)
    got = without_timings(result.report)
    cli.pop("task"), got.pop("task")
    cli.pop("mission_phase_build_ms"), got.pop("mission_phase_build_ms")
    assert got == cli


def test_a_moving_target_dict_plans_as_the_cli_plans_its_file(sdf_dir, tmp_path):
    """A cup moving at 0.15 m/s (goal.tool.motion) from a dict: met where it
    is at the arrival, the target columns in the trajectory, and the same
    plan and report as quadhand-plan's."""
    task = window_cup_dict()
    goal = task["goal"]
    for key in ("position", "yaw", "joints"):
        goal.pop(key)
    goal["tool"]["motion"] = {"velocity": [0.0, 0.15, 0.0],
                              "moving_points": {"min": [-3.36, -0.16, 0.49], "max": [-3.04, 0.16, 0.91]}}
    robot = quadhand.Robot(URDF, sdf_dir=sdf_dir)
    result = quadhand.plan(task, robot=robot, scene=quadhand.Scene.from_pcd(SCENE))
    assert result.success, result.message
    arrival = result.report["moving_target"]["arrival_s"]
    assert math.isclose(result.report["moving_target"]["target_position"][1], 0.15 * arrival, abs_tol=1e-9)
    assert result.report["moving_target"]["tool_to_target_m"] < 0.002
    assert result.columns[-7:] == ["target_x", "target_y", "target_z", "target_qw", "target_qx", "target_qy",
                                   "target_qz"]
    assert np.allclose(result.trajectory["target_y"], 0.15 * result.trajectory["t"], atol=1e-6)

    csv, report = plan_file_with_cli(task, sdf_dir, tmp_path)
    assert result.csv() == csv
    assert without_timings(report)["moving_target"] == without_timings(result.report)["moving_target"]
