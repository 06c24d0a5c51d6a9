"""Shared fixtures of the Python module's tests: the built module on the path,
coarse link SDFs of the reference robot made once per session by the module
itself, and the default task with absolute paths to them."""

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(os.environ.get("QUADHAND_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BIN_DIR = Path(os.environ.get("QUADHAND_BIN_DIR", ROOT / "build" / "bin"))
PYTHON_DIR = os.environ.get("QUADHAND_PYTHON_DIR", str(ROOT / "build" / "python"))
if PYTHON_DIR not in sys.path:
    sys.path.insert(0, PYTHON_DIR)

URDF = ROOT / "meshes" / "quadhand" / "quadhand.urdf"
SCENE = ROOT / "data" / "scenes" / "window_cup.pcd"
TASK = ROOT / "data" / "tasks" / "window_cup.yaml"


@pytest.fixture(scope="session")
def sdf_dir(tmp_path_factory):
    import quadhand

    folder = tmp_path_factory.mktemp("sdf")
    quadhand.generate_sdfs(URDF, folder, resolution=0.005, padding=0.05)
    return folder


def window_cup_text(sdf_dir):
    """The default task's text with absolute robot, SDF and scene paths."""
    lines = []
    for line in TASK.read_text().splitlines():
        if line.startswith("robot:"):
            line = f"robot: {URDF}"
        elif line.startswith("sdf_dir:"):
            line = f"sdf_dir: {sdf_dir}"
        elif line.startswith("scene:"):
            line = f"scene: {SCENE}"
        lines.append(line)
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="session")
def task_file(sdf_dir, tmp_path_factory):
    path = tmp_path_factory.mktemp("task") / "window_cup.yaml"
    path.write_text(window_cup_text(sdf_dir))
    return path
