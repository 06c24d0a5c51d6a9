"""Writes window-and-cup layouts the planner was never tuned on, for
robustness runs (docs/benchmark.md, "Unseen layouts"): narrower windows
(0.5 x 0.40 m instead of 0.6 x 0.45 m) at random heights and lateral
offsets, 2 mm Gaussian sensor noise on every point, and a tool-only goal (the
planner must find the hovering state itself). One scene and one task per
layout; deterministic for a given --seed.

Usage: python3 scripts/make_hard_layouts.py --out DIR [--count 5] [--seed 1]
Then:  for t in DIR/*.yaml; do build/bin/quadhand-plan $t --out /tmp/p.csv --report DIR/$(basename $t .yaml).json; done
"""
import argparse
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_window_cup_scene as scene  # noqa: E402


def wall(x_center, window_y, window_z, width, height):
    points = []
    for x in (x_center - 0.025, x_center + 0.025):
        for y in scene.frange(-1.5, 1.5, 0.02):
            for z in scene.frange(0.0, 2.5, 0.02):
                if abs(y - window_y) < width / 2 and abs(z - window_z) < height / 2:
                    continue
                points.append((x, y, z))
    return points


TASK = """# An unseen layout (scripts/make_hard_layouts.py, seed {seed}, layout {index}):
# windows {width} x {height} m at (y, z) = ({y1:.3f}, {z1:.3f}) and ({y2:.3f}, {z2:.3f}),
# {noise} m sensor noise, tool-only goal.
robot: {root}/meshes/quadhand/quadhand.urdf
sdf_dir: {root}/data/sdf/quadhand
scene: {scene}
start:
  position: [0.5, 0.2, 1.2]
  yaw: 3.14159265
  joints: [0.3, -0.2, 0.0]
goal:
  tool:
    position: [-3.2, 0.0, 0.86]
    orientation: [0.0, -0.7071067812, 0.0, 0.7071067812]
    insertion: {{direction: [0, 0, -1], length: 0.10}}
limits:
  v_max: 2.0
  a_max: 4.0
  yaw_rate_max: 1.5
  body_rate_xy_max: 3.0
safety_distance: 0.03
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for the scenes and tasks (made if missing)")
    parser.add_argument("--count", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--noise", type=float, default=0.002, help="standard deviation of the sensor noise, m")
    parser.add_argument("--width", type=float, default=0.5)
    parser.add_argument("--height", type=float, default=0.40)
    args = parser.parse_args()
    if args.count < 1 or args.noise < 0 or args.width <= 0 or args.height <= 0:
        sys.exit("make_hard_layouts: --count must be positive, --noise non-negative, windows positive")
    os.makedirs(args.out, exist_ok=True)
    rng = random.Random(args.seed)
    root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    for index in range(args.count):
        y1, y2 = rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)
        z1, z2 = rng.uniform(0.8, 1.7), rng.uniform(0.8, 1.7)
        parts = (scene.floor_points() + wall(-1.0, y1, z1, args.width, args.height) +
                 wall(-2.2, y2, z2, args.width, args.height) + scene.box_surface((-3.2, 0.0, 0.65), 0.3, 0.01) +
                 scene.cup_points(-3.2, 0.0, 0.8, 0.10, 0.04, 0.035, 0.005))
        noisy = [tuple(c + rng.gauss(0.0, args.noise) for c in p) for p in parts]
        scene_path = os.path.abspath(os.path.join(args.out, f"layout{index}.pcd"))
        scene.write_binary_pcd(scene_path, noisy)
        with open(os.path.join(args.out, f"layout{index}.yaml"), "w") as out:
            out.write(TASK.format(seed=args.seed, index=index, width=args.width, height=args.height, y1=y1, z1=z1,
                                  y2=y2, z2=z2, noise=args.noise, root=root, scene=scene_path))
        print(f"layout {index}: windows at (y, z) = ({y1:.3f}, {z1:.3f}), ({y2:.3f}, {z2:.3f}); {len(noisy)} points")


if __name__ == "__main__":
    main()
