#!/usr/bin/env python3
"""Writes the scenes of the bundled missions (docs/missions.md) as binary PCD
files, built to the sizes of the paper's real-world missions. Deterministic:
the same files every run.

  gap_crossing.pcd: a floor, a wall with a 0.6 x 0.35 m gap (its centre at
      z = 1.2 m), and behind it a 0.5 m cube with a cup (70/80 mm inner/outer
      diameter, 0.10 m tall) standing on it, in a closed room (5 x 3 x 2.5 m)
      that the wall divides. The gap-crossing grasp and the narrow-gap
      crossing fly through the gap: there is no other way.
  drone_rescue.pcd: a DJI Tello on the floor, 2 cm under the edge of a
      storage box on short feet (the drone rescue).
  cable_unplugging.pcd: a USB plug in the side of a cabinet (the cable
      unplugging; the cable itself is left out).
  plier_placement.pcd: a pegboard with a hook (the plier placement).

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


def box_faces(lo, hi, step=0.01):
    """Points every `step` on the six faces of the axis-aligned box [lo, hi]."""
    points = set()
    axes = [frange(lo[a], hi[a], step) for a in range(3)]
    for a in range(3):
        b, c = [k for k in range(3) if k != a]
        for value in (lo[a], hi[a]):
            for u in axes[b]:
                for v in axes[c]:
                    p = [0.0, 0.0, 0.0]
                    p[a], p[b], p[c] = value, u, v
                    points.add(tuple(round(x, 9) for x in p))
    return sorted(points)


def board_with_holes(x, y0, y1, z0, z1, pitch=0.025, hole=0.006, step=0.005):
    """A pegboard: the plane at `x` facing +x, with round holes `pitch` apart."""
    points = []
    for y in frange(y0, y1, step):
        for z in frange(z0, z1, step):
            dy = (y - y0) % pitch - pitch / 2
            dz = (z - z0) % pitch - pitch / 2
            if dy * dy + dz * dz < hole * hole:
                continue
            points.append((x, y, z))
    return points


def cylinder_x(x0, x1, y, z, radius, step=0.003):
    """The surface of a cylinder along x, end caps included."""
    import math
    count = max(8, int(round(2 * math.pi * radius / step)))
    points = []
    for x in frange(x0, x1, step):
        for k in range(count):
            a = 2 * math.pi * k / count
            points.append((x, y + radius * math.cos(a), z + radius * math.sin(a)))
    for r in frange(0.0, radius, step):
        for k in range(max(1, int(round(2 * math.pi * r / step)))):
            a = 2 * math.pi * k / max(1, int(round(2 * math.pi * r / step)))
            points.append((x1, y + r * math.cos(a), z + r * math.sin(a)))
    return points


SCENES = {
    "gap_crossing.pcd": lambda: {
        "floor": floor(-3.5, 1.5, -1.5, 1.5),
        "wall with a 0.6 x 0.35 m gap at z = 1.2": wall_with_gap(-1.0, 0.6, 0.35, 1.2),
        # The room the wall divides (its ceiling, side and end walls): the
        # gap is the only way to the far side, not over or round the wall.
        "room (5 x 3 x 2.5 m)": box_faces((-3.5, -1.5, 0.0), (1.5, 1.5, 2.5), 0.04),
        "cube (0.5 m)": box_surface((-2.2, 0.0, 0.25), 0.5, 0.01),
        "cup (70/80 mm, 0.10 m)": cup_points(-2.2, 0.0, 0.5, 0.10, 0.04, 0.035, 0.005),
    },
    # A DJI Tello (98 x 93 x 41 mm, 3 mm above the floor) 2 cm under the edge
    # of a storage box (0.57 x 0.6 x 0.22 m) on 6 cm feet.
    "drone_rescue.pcd": lambda: {
        "floor": floor(-3.5, 1.5, -1.5, 1.5),
        "storage box": box_faces((-2.6, -0.3, 0.06), (-2.03, 0.3, 0.28)),
        "its feet": box_faces((-2.6, -0.3, 0.0), (-2.5, 0.3, 0.06)) + box_faces((-2.13, -0.3, 0.0), (-2.03, -0.2, 0.06))
        + box_faces((-2.13, 0.2, 0.0), (-2.03, 0.3, 0.06)),
        "Tello": box_faces((-2.049, -0.0465, 0.003), (-1.951, 0.0465, 0.044), 0.005),
    },
    # A cabinet (0.3 x 0.8 x 0.6 m) with a socket in its +x face at z = 0.45;
    # a USB plug (80 x 16 x 10 mm) sticks out of it along +x.
    "cable_unplugging.pcd": lambda: {
        "floor": floor(-3.5, 1.5, -1.5, 1.5),
        "cabinet": box_faces((-2.6, -0.4, 0.0), (-2.3, 0.4, 0.6)),
        "USB plug": box_faces((-2.3, -0.008, 0.445), (-2.22, 0.008, 0.455), 0.004),
    },
    # A pegboard (the plane x = -2.5, 1 m wide, z 0.6 to 1.4 m, holes every
    # 25 mm) with a hook: a 12 mm peg sticking out 0.10 m at z = 1.0 m.
    "plier_placement.pcd": lambda: {
        "floor": floor(-3.5, 1.5, -1.5, 1.5),
        "pegboard": board_with_holes(-2.5, -0.5, 0.5, 0.6, 1.4),
        "hook": cylinder_x(-2.5, -2.4, 0.0, 1.0, 0.006),
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
