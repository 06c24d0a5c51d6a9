"""Bad input to the Python module: quadhand.Error (a ValueError) naming the
argument or file and the problem, the same line the programs print, and
never a crash of the interpreter."""

import subprocess

import numpy as np
import pytest

import quadhand
from conftest import BIN_DIR, SCENE, URDF
from test_plan import window_cup_dict


def message(call):
    with pytest.raises(ValueError) as raised:
        call()
    assert isinstance(raised.value, quadhand.Error)
    text = str(raised.value)
    assert "\n" not in text
    return text


@pytest.fixture(scope="module")
def robot(sdf_dir):
    return quadhand.Robot(URDF, sdf_dir=sdf_dir)


@pytest.fixture(scope="module")
def scene():
    return quadhand.Scene.from_pcd(SCENE)


@pytest.mark.parametrize("points, expected", [
    (np.zeros((5, 2)), "points: expected an N x 3 array, got shape (5, 2)"),
    (np.zeros(3), "points: expected an N x 3 array, got shape (3,)"),
    (np.zeros((0, 3)), "points: the cloud is empty"),
    (np.zeros((4, 3), dtype=np.int64), "points: expected float64 or float32 values, got dtype int64"),
    (np.array([["a", "b", "c"]]), "points: expected float64 or float32 values"),
    (np.array([[0, 0, 0], [np.nan, 1, 2], [0, np.inf, 0]]), "points: 2 row(s) are not finite, the first is row 1"),
])
def test_scene_arrays(points, expected):
    assert message(lambda: quadhand.Scene(points)).startswith(expected)


def test_scene_accepts_float32_and_any_layout():
    points = np.asfortranarray(np.arange(12, dtype=np.float32).reshape(4, 3))
    assert np.array_equal(quadhand.Scene(points).points, points.astype(np.float64))
    assert np.array_equal(quadhand.Scene(points[::2]).points, points[::2].astype(np.float64))


def test_files_that_are_missing_or_malformed(tmp_path, robot):
    missing = tmp_path / "nope.pcd"
    assert str(missing) in message(lambda: quadhand.Scene.from_pcd(missing))
    garbage = tmp_path / "garbage.pcd"
    garbage.write_bytes(b"\x00\x01not a pcd")
    assert str(garbage) in message(lambda: quadhand.Scene.from_pcd(garbage))
    assert str(tmp_path / "r.urdf") in message(lambda: quadhand.Robot(tmp_path / "r.urdf"))
    bad_task = tmp_path / "task.yaml"
    bad_task.write_text("start: [unclosed\n")
    assert message(lambda: quadhand.plan(bad_task, robot=robot)).startswith(f"{bad_task}: not valid YAML")
    assert str(tmp_path / "none.yaml") in message(lambda: quadhand.plan(tmp_path / "none.yaml"))


def test_the_same_message_as_the_cli(tmp_path):
    bad_task = tmp_path / "task.yaml"
    bad_task.write_text("robot: r.urdf\nsdf_dir: s\nscene: c.pcd\nstart: {position: [0, 0]}\n")
    cli = subprocess.run([str(BIN_DIR / "quadhand-plan"), str(bad_task), "--out", str(tmp_path / "p.csv"),
                          "--report", str(tmp_path / "r.json")], capture_output=True, text=True)
    assert cli.returncode == 2
    assert cli.stderr.strip() == "quadhand-plan: error: " + message(lambda: quadhand.plan(bad_task))
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "r.json").exists()


def test_task_dicts(robot, scene):
    task = window_cup_dict()
    del task["start"]
    assert message(lambda: quadhand.plan(task, robot=robot, scene=scene)) == "task: start: missing"
    task = window_cup_dict()
    task["start"]["yaw"] = float("nan")
    assert message(lambda: quadhand.plan(task, robot=robot, scene=scene)).startswith("task: start.yaw: expected a number")
    task = window_cup_dict()
    task["start"]["position"] = [0, 0, float("inf")]
    assert "start.position[2]" in message(lambda: quadhand.plan(task, robot=robot, scene=scene))
    task = window_cup_dict()
    task["start"]["joints"] = [0.3, -0.2]
    assert "start.joints" in message(lambda: quadhand.plan(task, robot=robot, scene=scene))
    task = window_cup_dict()
    task["colour"] = "red"
    assert message(lambda: quadhand.plan(task, robot=robot, scene=scene)).startswith("task: colour: unknown key")
    task = window_cup_dict()
    task["start"]["yaw"] = object()
    assert message(lambda: quadhand.plan(task, robot=robot, scene=scene)).startswith("task: a value of type object")
    # Without robot and scene the dict must name them.
    assert message(lambda: quadhand.plan(window_cup_dict())) == "task: robot: expected a file or folder path"
    assert message(lambda: quadhand.plan(42)).startswith("task: expected a dict or a path")


def test_plan_options(robot, scene):
    task = window_cup_dict()
    plan = lambda **kw: quadhand.plan(task, robot=robot, scene=scene, **kw)  # noqa: E731
    assert message(lambda: plan(solver="newton")).startswith("solver: ")
    assert message(lambda: plan(solver=3)) == "solver: expected a name, got int"
    assert message(lambda: plan(representation="voxels")).startswith("unknown representation 'voxels'")
    assert message(lambda: plan(dt=0.0)) == "dt: must be in (0, 1] seconds"
    assert message(lambda: plan(dt=float("nan"))) == "dt: must be in (0, 1] seconds"
    assert message(lambda: plan(dt="fast")) == "dt: expected a number of seconds, got 'fast'"
    assert message(lambda: plan(seed=-1)).startswith("seed: expected an integer")
    assert message(lambda: quadhand.plan(task, robot=quadhand.Robot(URDF), scene=scene)).startswith(
        "robot: no sdf_dir was given")
    assert message(lambda: quadhand.plan(task, robot="robot.urdf", scene=scene)).startswith(
        "robot: expected a quadhand.Robot")


def test_generate_sdfs_options(tmp_path):
    out = tmp_path / "sdf"
    assert message(lambda: quadhand.generate_sdfs(URDF, out, resolution=-1)).startswith("invalid option:")
    assert message(lambda: quadhand.generate_sdfs(URDF, out, links=["wing"])) == f"{URDF}: no link named 'wing'"
    assert message(lambda: quadhand.generate_sdfs(URDF, out, threads=-2)).startswith("threads:")
    assert message(lambda: quadhand.generate_sdfs(tmp_path / "x.urdf", out)).startswith(str(tmp_path / "x.urdf"))
    assert not out.exists() or not any(out.iterdir())


def test_exact_clearance_arguments(robot):
    clearance = quadhand.ExactClearance(robot, np.array([[1.0, 1.0, 1.0]]))
    assert message(lambda: clearance.query([0, 0, 1], [0.0, 0.0])).startswith("joints: expected 3 numbers")
    assert message(lambda: clearance.query([0, 0], [0, 0, 0])).startswith("position: expected 3 numbers")
    assert message(lambda: clearance.query([0, 0, np.nan], [0, 0, 0])).startswith("position: must be finite")
    assert message(lambda: clearance.query([0, 0, 1], [0, 0, 0], attitude=[2, 0, 0, 0])).startswith(
        "attitude: expected a unit quaternion")
    assert message(lambda: clearance.query([0, 0, 1], [0, 0, 0], yaw=0, attitude=[1, 0, 0, 0])).startswith(
        "attitude: give either")
    assert message(lambda: clearance.query([0, 0, 1], [0, 0, 0], reach=0)) == "reach: must be positive"
