"""Writes window courses of increasing length, for the plan-length scaling
figures (docs/benchmark.md, "Plan length"): K walls 1.2 m apart along -x,
each with one 0.6 x 0.45 m window (the benchmark's size) alternating
between two heights and sides, then the cup on its table 1.2 m behind the
last wall. The task is the default one's (same start, robot, limits, the
same hover state relative to the cup and the 0.10 m insertion), so only the
length changes. One scene and one task per K.

Usage: python3 scripts/make_long_course.py --out DIR [--walls 1,2,4,8]
Then:  for t in DIR/course*.yaml; do build/bin/quadhand-plan $t --out /tmp/p.csv --report ${t%.yaml}.json; done
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_window_cup_scene as scene  # noqa: E402

SPACING = 1.2   # m between walls
FIRST = -1.0    # x of the first wall (the benchmark's)
WINDOW = (0.6, 0.45)


def wall(x_center, window_y, window_z, y_half):
    points = []
    for x in (x_center - 0.025, x_center + 0.025):
        for y in scene.frange(-y_half, y_half, 0.02):
            for z in scene.frange(0.0, 2.5, 0.02):
                if abs(y - window_y) < WINDOW[0] / 2 and abs(z - window_z) < WINDOW[1] / 2:
                    continue
                points.append((x, y, z))
    return points


TASK = """# A course of {walls} wall(s) (scripts/make_long_course.py): windows {width} x {height} m
# 1.2 m apart, the cup 1.2 m behind the last; the default task's start, robot and limits.
robot: {root}/meshes/quadhand/quadhand.urdf
sdf_dir: {root}/data/sdf/quadhand
scene: {scene}
start:
  position: [0.5, 0.2, 1.2]
  yaw: 3.14159265
  joints: [0.3, -0.2, 0.0]
goal:
  position: [{gx:.9f}, 0.0, 1.287928495]
  yaw: 3.14159265
  joints: [0.6, 0.9707963268, 0.0]
  tool:
    position: [{cx:.9f}, 0.0, 0.86]
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
    parser.add_argument("--walls", default="1,2,4,8", help="comma-separated wall counts")
    args = parser.parse_args()
    try:
        counts = [int(w) for w in args.walls.split(",")]
    except ValueError:
        sys.exit("make_long_course: --walls must be whole numbers separated by commas")
    if not counts or min(counts) < 1 or max(counts) > 32:
        sys.exit("make_long_course: each wall count must be in 1..32")
    os.makedirs(args.out, exist_ok=True)
    root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    for walls in counts:
        cup_x = FIRST - SPACING * (walls - 1) - SPACING
        points = [(x, y, 0.0) for x in scene.frange(cup_x - 0.8, 1.5, 0.02) for y in scene.frange(-1.5, 1.5, 0.02)]
        for k in range(walls):
            window_y = 0.15 if k % 2 == 0 else -0.15
            window_z = 1.0 if k % 2 == 0 else 1.35
            points += wall(FIRST - SPACING * k, window_y, window_z, 1.5)
        points += scene.box_surface((cup_x, 0.0, 0.65), 0.3, 0.01)
        points += scene.cup_points(cup_x, 0.0, 0.8, 0.10, 0.04, 0.035, 0.005)
        scene_path = os.path.abspath(os.path.join(args.out, f"course{walls}.pcd"))
        scene.write_binary_pcd(scene_path, points)
        with open(os.path.join(args.out, f"course{walls}.yaml"), "w") as out:
            out.write(TASK.format(walls=walls, width=WINDOW[0], height=WINDOW[1], root=root, scene=scene_path,
                                  gx=cup_x + 0.205067123, cx=cup_x))
        print(f"course of {walls} wall(s): cup at x = {cup_x:.2f} m, {len(points)} points")


if __name__ == "__main__":
    main()
