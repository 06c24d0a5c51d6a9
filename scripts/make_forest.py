"""Writes a random forest and a task to fly through it (docs/perception.md,
"Known scenes at scale"): tree trunks, vertical cylinders of points, placed
by a Poisson process of `--density` trees per square metre over a strip
`--length` long (along +x) and `--width` wide, with a floor if asked. The
start stands at x = 0 and the goal (a hover, arm stowed) at x = length, both
mid-strip and at `--altitude`; no trunk is placed within `--clear` of
either. Seeded: the same arguments give the same files.

Usage: python3 scripts/make_forest.py --length 30 --out DIR [--seed 1]
       [--density 0.15] [--width 8] [--floor]
Writes DIR/forest_L<length>_s<seed>.pcd and .yaml (the task, robot and SDFs
of the repository's reference robot, absolute paths).
"""
import argparse
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_window_cup_scene as scene  # noqa: E402

TASK = """# A {length:g} m forest (scripts/make_forest.py --length {length:g} --seed {seed} --density {density:g}
# --width {width:g}): {trees} trunks, {points} points. The start and the goal are
# mid-strip at {altitude:g} m; the goal is a hover with the arm stowed.
robot: {root}/meshes/quadhand/quadhand.urdf
sdf_dir: {root}/data/sdf/quadhand
scene: {scene}
start:
  position: [0.0, 0.0, {altitude:g}]
  yaw: 0.0
  joints: [0.3, -0.2, 0.0]
goal:
  position: [{length:g}, 0.0, {altitude:g}]
  yaw: 0.0
  joints: [0.3, -0.2, 0.0]
limits: {{v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}}
safety_distance: 0.03
"""


def poisson(rng, mean):
    """Knuth's method for small means, a rounded normal for large ones."""
    if mean > 500:
        return max(0, int(round(rng.gauss(mean, math.sqrt(mean)))))
    limit, k, p = math.exp(-mean), 0, 1.0
    while True:
        p *= rng.random()
        if p <= limit:
            return k
        k += 1


def trunk(x, y, radius, height, spacing):
    points = []
    around = max(6, int(math.ceil(2 * math.pi * radius / spacing)))
    for z in scene.frange(0.0, height, spacing):
        for k in range(around):
            a = 2 * math.pi * k / around
            points.append((x + radius * math.cos(a), y + radius * math.sin(a), z))
    return points


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for the .pcd and the task .yaml")
    parser.add_argument("--length", type=float, default=30.0, help="m along +x (default 30)")
    parser.add_argument("--width", type=float, default=8.0, help="m across (default 8)")
    parser.add_argument("--density", type=float, default=0.15, help="trees per m^2 (default 0.15)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--radius", type=float, nargs=2, default=(0.1, 0.25), metavar=("MIN", "MAX"),
                        help="trunk radius range, m (default 0.1 0.25)")
    parser.add_argument("--height", type=float, default=4.0, help="trunk height, m (default 4)")
    parser.add_argument("--spacing", type=float, default=0.05, help="point spacing on a trunk, m (default 0.05)")
    parser.add_argument("--altitude", type=float, default=1.2, help="start and goal height, m (default 1.2)")
    parser.add_argument("--clear", type=float, default=1.0, help="no trunk within this of start or goal, m")
    parser.add_argument("--floor", action="store_true", help="add a floor of points every 0.1 m")
    args = parser.parse_args()
    for name in ("length", "width", "density", "height", "spacing"):
        if not getattr(args, name) > 0 or not math.isfinite(getattr(args, name)):
            parser.error(f"--{name} must be a positive number")
    if not 0 < args.radius[0] <= args.radius[1]:
        parser.error("--radius MIN MAX must have 0 < MIN <= MAX")

    rng = random.Random(args.seed)
    # The strip runs from a metre before the start to a metre past the goal.
    x0, x1 = -1.0, args.length + 1.0
    y0, y1 = -args.width / 2, args.width / 2
    count = poisson(rng, args.density * (x1 - x0) * (y1 - y0))
    ends = [(0.0, 0.0), (args.length, 0.0)]
    trees = []
    for _ in range(count):
        x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
        radius = rng.uniform(*args.radius)
        if any(math.hypot(x - ex, y - ey) < args.clear + radius for ex, ey in ends):
            continue
        trees.append((x, y, radius))
    points = []
    for x, y, radius in trees:
        points += trunk(x, y, radius, args.height, args.spacing)
    if args.floor:
        for x in scene.frange(x0, x1, 0.1):
            for y in scene.frange(y0, y1, 0.1):
                points.append((x, y, 0.0))
    if not points:
        parser.error("no trunk was placed: raise --density or --length")
    os.makedirs(args.out, exist_ok=True)
    stem = os.path.join(args.out, f"forest_L{args.length:g}_s{args.seed}")
    scene.write_binary_pcd(stem + ".pcd", points, title=f"forest (scripts/make_forest.py, seed {args.seed})")
    root = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    with open(stem + ".yaml", "w") as out:
        out.write(TASK.format(length=args.length, seed=args.seed, density=args.density, width=args.width,
                              trees=len(trees), points=len(points), altitude=args.altitude, root=root,
                              scene=os.path.abspath(stem + ".pcd")))
    print(f"{stem}.pcd: {len(trees)} trunks, {len(points)} points; task {stem}.yaml")


if __name__ == "__main__":
    main()
