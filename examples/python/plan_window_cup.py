#!/usr/bin/env python3
"""Plans the window-and-cup task from Python, with the robot, the scene and
the task given as objects rather than files, then looks at the result.

Run after `bash scripts/quickstart.sh` (it builds the module and the link
SDFs), from the repository root:

    PYTHONPATH=build/python python3 examples/python/plan_window_cup.py [SDF_DIR]

(SDF_DIR: the reference robot's link SDFs, data/sdf/quadhand by default) or,
with QuadHand installed (cmake --install build --prefix P), with
PYTHONPATH=P/lib/python3/dist-packages.
"""

import sys
from pathlib import Path

import numpy as np

import quadhand

root = Path(__file__).resolve().parents[2]
sdf_dir = sys.argv[1] if len(sys.argv) > 1 else root / "data/sdf/quadhand"
robot = quadhand.Robot(root / "meshes/quadhand/quadhand.urdf", sdf_dir=sdf_dir)

# Any N x 3 array in metres works as a scene; here the bundled PCD's points.
cloud = quadhand.Scene.from_pcd(root / "data/scenes/window_cup.pcd").points
scene = quadhand.Scene(np.asarray(cloud))

task = {
    "start": {"position": [0.5, 0.2, 1.2], "yaw": np.pi, "joints": [0.3, -0.2, 0.0]},
    "goal": {
        "position": [-2.994932877, 0.0, 1.287928495],
        "yaw": np.pi,
        "joints": [0.6, np.pi / 2 - 0.6, 0.0],
        "tool": {"position": [-3.2, 0.0, 0.86], "orientation": [0.0, -np.sqrt(0.5), 0.0, np.sqrt(0.5)],
                 "insertion": {"direction": [0, 0, -1], "length": 0.10}},
    },
    "limits": {"v_max": 2.0, "a_max": 4.0},
    "safety_distance": 0.03,
}

try:
    result = quadhand.plan(task, robot=robot, scene=scene, solver="lbfgs")
except quadhand.Error as error:
    sys.exit(f"bad input: {error}")

report = result.report
print(f"{result.status}: {result.message}")
print(f"optimisation {report['solve_ms']:.1f} ms, {report['iterations']} iterations, "
      f"duration {report['duration_s']:.2f} s, exact clearance {report['min_clearance_exact_m'] * 100:.2f} cm "
      f"({report['closest_link']})")
if not result.success:
    sys.exit(1)

traj = result.trajectory
speed = np.linalg.norm(np.column_stack([traj["vx"], traj["vy"], traj["vz"]]), axis=1)
print(f"{len(traj['t'])} samples; peak speed {speed.max():.2f} m/s at t = {traj['t'][speed.argmax()]:.2f} s")

# The exact clearance of the final state, as the post-check measures it.
last = result.table[-1]
joints = [traj[name][-1] for name in robot.joint_names]
distance, link = quadhand.exact_clearance(robot, scene, last[1:4], joints, attitude=last[10:14])
print(f"final state: {distance * 100:.2f} cm from the scene ({link})")
