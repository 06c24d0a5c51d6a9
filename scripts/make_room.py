"""Writes a random room and a task to fly across it (docs/perception.md):
a closed room (floor, ceiling, end and side walls) `--length` long along +x,
cut by `--walls` inner walls, each with one opening placed at random: a door
(floor to `--door-height`, `--door-width` wide) or a window (`--window`
width and height, its bottom at a random height). The start stands in the
first compartment and the goal (a hover, arm stowed) in the last, both
mid-room at `--altitude`. Seeded: the same arguments give the same files.

Usage: python3 scripts/make_room.py --out DIR [--seed 1] [--length 12] [--walls 2]
Writes DIR/room_s<seed>.pcd and .yaml (the task, robot and SDFs of the
repository's reference robot, absolute paths).
"""
import argparse
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_window_cup_scene as scene  # noqa: E402

TASK = """# A room (scripts/make_room.py --seed {seed} --length {length:g} --walls {walls}): {openings}.
# {points} points. The start and the goal are mid-room at {altitude:g} m, at its two ends.
robot: {root}/meshes/quadhand/quadhand.urdf
sdf_dir: {root}/data/sdf/quadhand
scene: {scene}
start:
  position: [{start_x:g}, 0.0, {altitude:g}]
  yaw: 0.0
  joints: [0.3, -0.2, 0.0]
goal:
  position: [{goal_x:g}, 0.0, {altitude:g}]
  yaw: 0.0
  joints: [0.3, -0.2, 0.0]
limits: {{v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}}
safety_distance: 0.03
"""


def plane(fixed_axis, fixed, ranges, step, hole=None):
    """Points on an axis-aligned rectangle: `fixed_axis` (0, 1, 2) at `fixed`,
    the other two axes over `ranges`; `hole` (lo_a, hi_a, lo_b, hi_b) left out."""
    (a0, a1), (b0, b1) = ranges
    points = []
    for a in scene.frange(a0, a1, step):
        for b in scene.frange(b0, b1, step):
            if hole and hole[0] < a < hole[1] and hole[2] < b < hole[3]:
                continue
            p = [0.0, 0.0, 0.0]
            others = [axis for axis in range(3) if axis != fixed_axis]
            p[fixed_axis], p[others[0]], p[others[1]] = fixed, a, b
            points.append(tuple(p))
    return points


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for the .pcd and the task .yaml")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--length", type=float, default=12.0, help="m along +x (default 12)")
    parser.add_argument("--width", type=float, default=5.0, help="m across (default 5)")
    parser.add_argument("--height", type=float, default=2.8, help="m (default 2.8)")
    parser.add_argument("--walls", type=int, default=2, help="inner walls, each with one opening (default 2)")
    parser.add_argument("--door-width", type=float, default=0.9)
    parser.add_argument("--door-height", type=float, default=2.0)
    parser.add_argument("--window", type=float, nargs=2, default=(0.8, 0.6), metavar=("WIDTH", "HEIGHT"))
    parser.add_argument("--door-fraction", type=float, default=0.5, help="share of openings that are doors")
    parser.add_argument("--step", type=float, default=0.03, help="point spacing, m (default 0.03)")
    parser.add_argument("--altitude", type=float, default=1.2)
    args = parser.parse_args()
    if not (args.length > 2.0 and args.width > 1.5 and args.height > 1.5 and args.step > 0.0):
        parser.error("--length > 2, --width > 1.5, --height > 1.5 and --step > 0 are needed")
    if args.walls < 0 or (args.walls + 1) * 1.5 > args.length:
        parser.error("--walls must leave at least 1.5 m between walls")
    rng = random.Random(args.seed)
    half_w, step = args.width / 2, args.step
    points = []
    points += plane(2, 0.0, ((0.0, args.length), (-half_w, half_w)), step)          # floor
    points += plane(2, args.height, ((0.0, args.length), (-half_w, half_w)), step)  # ceiling
    points += plane(0, 0.0, ((-half_w, half_w), (0.0, args.height)), step)          # end walls
    points += plane(0, args.length, ((-half_w, half_w), (0.0, args.height)), step)
    points += plane(1, -half_w, ((0.0, args.length), (0.0, args.height)), step)     # side walls
    points += plane(1, half_w, ((0.0, args.length), (0.0, args.height)), step)
    spacing = args.length / (args.walls + 1)
    openings = []
    for k in range(args.walls):
        x = spacing * (k + 1)
        door = rng.random() < args.door_fraction
        width, height = (args.door_width, args.door_height) if door else tuple(args.window)
        centre = rng.uniform(-half_w + width / 2 + 0.2, half_w - width / 2 - 0.2)
        bottom = 0.0 if door else rng.uniform(0.5, args.height - height - 0.3)
        hole = (centre - width / 2, centre + width / 2, bottom, bottom + height)
        points += plane(0, x, ((-half_w, half_w), (0.0, args.height)), step, hole)
        openings.append(f"{'a door' if door else 'a window'} at x = {x:.2f} m, y = {centre:.2f} m, z {bottom:.2f}-{bottom + height:.2f} m")
    os.makedirs(args.out, exist_ok=True)
    stem = os.path.join(args.out, f"room_s{args.seed}")
    scene.write_binary_pcd(stem + ".pcd", points, title=f"room (scripts/make_room.py, seed {args.seed})")
    root = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    with open(stem + ".yaml", "w") as out:
        out.write(TASK.format(seed=args.seed, length=args.length, walls=args.walls,
                              openings="; ".join(openings) if openings else "no inner wall", points=len(points),
                              altitude=args.altitude, root=root, scene=os.path.abspath(stem + ".pcd"),
                              start_x=min(1.0, spacing / 2), goal_x=args.length - min(1.0, spacing / 2)))
    print(f"{stem}.pcd: {len(points)} points, {'; '.join(openings)}; task {stem}.yaml")


if __name__ == "__main__":
    main()
