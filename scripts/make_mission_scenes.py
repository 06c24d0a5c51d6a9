#!/usr/bin/env python3
"""Writes the scenes of the bundled missions (docs/missions.md) as binary PCD
files, built to the sizes of the paper's real-world missions. Deterministic:
the same files every run.

  gap_crossing.pcd: a floor, a wall with a 0.6 x 0.35 m gap (its centre at
      z = 1.2 m), and behind it a 0.5 m cube with a cup (70/80 mm inner/outer
      diameter, 0.10 m tall) standing on it. The gap-crossing grasp and the
      narrow-gap crossing fly through it.

Usage: python3 scripts/make_mission_scenes.py [--out-dir data/scenes]
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_window_cup_scene import box_surface, cup_points, frange, write_binary_pcd  # noqa: E402


def floor(x0, x1, y0, y1, step=0.02):
    return [(x, y, 0.0) for x in frange(x0, x1, step) for y in frange(y0, y1, step)]


def wall_with_gap(x_center, gap_width, gap_height, gap_z, step=0.02, edge_step=0.01):
    """Plane x = x_center, 0.05 m thick (both faces), 3 m wide, 2.5 m tall,
    with a gap_width x gap_height opening centred at (y = 0, z = gap_z)."""
    points = []
    for x in (x_center - 0.025, x_center + 0.025):
        for y in frange(-1.5, 1.5, step):
            for z in frange(0.0, 2.5, step):
                if abs(y) < gap_width / 2 and abs(z - gap_z) < gap_height / 2:
                    continue
                points.append((x, y, z))
    # The opening's sides (the wall's thickness), so that the gap's edges are solid.
    for x in frange(x_center - 0.025, x_center + 0.025, edge_step):
        for y in frange(-gap_width / 2, gap_width / 2, edge_step):
            points.append((x, y, gap_z - gap_height / 2))
            points.append((x, y, gap_z + gap_height / 2))
        for z in frange(gap_z - gap_height / 2, gap_z + gap_height / 2, edge_step):
            points.append((x, -gap_width / 2, z))
            points.append((x, gap_width / 2, z))
    return points


SCENES = {
    "gap_crossing.pcd": lambda: {
        "floor": floor(-3.5, 1.5, -1.5, 1.5),
        "wall with a 0.6 x 0.35 m gap at z = 1.2": wall_with_gap(-1.0, 0.6, 0.35, 1.2),
        "cube (0.5 m)": box_surface((-2.2, 0.0, 0.25), 0.5, 0.01),
        "cup (70/80 mm, 0.10 m)": cup_points(-2.2, 0.0, 0.5, 0.10, 0.04, 0.035, 0.005),
    },
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", default=os.path.join(os.path.dirname(__file__), "..", "data", "scenes"))
    args = parser.parse_args()
    os.makedirs(args.out_dir, exist_ok=True)
    for name, make in SCENES.items():
        parts = make()
        points = [p for part in parts.values() for p in part]
        path = os.path.join(args.out_dir, name)
        write_binary_pcd(path, points, f"QuadHand mission scene {name} (scripts/make_mission_scenes.py)")
        for part, part_points in parts.items():
            print(f"  {part}: {len(part_points)} points")
        print(f"wrote {len(points)} points to {os.path.normpath(path)}")


if __name__ == "__main__":
    main()
