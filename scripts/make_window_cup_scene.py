#!/usr/bin/env python3
"""Writes the window-and-cup benchmark scene (shared/spec/benchmark.md) as a
binary PCD file: floor, two walls with windows at different heights, a
pedestal and a cup on it. Deterministic: the same file every run.

Usage: python3 scripts/make_window_cup_scene.py [--out data/scenes/window_cup.pcd]
"""
import argparse
import math
import os
import struct


def frange(start, stop, step):
    """start, start + step, ... up to stop inclusive (within rounding)."""
    count = int(math.floor((stop - start) / step + 1e-9)) + 1
    return [start + i * step for i in range(count)]


def floor_points():
    return [(x, y, 0.0) for x in frange(-4.0, 1.5, 0.02) for y in frange(-1.5, 1.5, 0.02)]


def wall_points(x_center, window_z):
    """Plane x = x_center, 0.05 m thick (both faces), with a 0.6 x 0.45 m opening."""
    points = []
    for x in (x_center - 0.025, x_center + 0.025):
        for y in frange(-1.5, 1.5, 0.02):
            for z in frange(0.0, 2.5, 0.02):
                if abs(y) < 0.3 and abs(z - window_z) < 0.225:
                    continue
                points.append((x, y, z))
    return points


def box_surface(center, size, step):
    """Points every `step` on the six faces of an axis-aligned box."""
    cx, cy, cz = center
    half = size / 2.0
    grid = frange(-half, half, step)
    points = set()
    for u in grid:
        for v in grid:
            for sign in (-half, half):
                points.add((round(cx + sign, 9), round(cy + u, 9), round(cz + v, 9)))
                points.add((round(cx + u, 9), round(cy + sign, 9), round(cz + v, 9)))
                points.add((round(cx + u, 9), round(cy + v, 9), round(cz + sign, 9)))
    return sorted(points)


def cup_points(cx, cy, z_bottom, height, r_outer, r_inner, step):
    """Outer and inner walls, rim annulus and bottom disc, every `step`."""
    points = []
    for radius in (r_outer, r_inner):
        count = max(8, int(round(2 * math.pi * radius / step)))
        for z in frange(z_bottom, z_bottom + height, step):
            for k in range(count):
                a = 2 * math.pi * k / count
                points.append((cx + radius * math.cos(a), cy + radius * math.sin(a), z))
    # Rim: the annulus between the walls at the top.
    for radius in frange(r_inner, r_outer, step / 2):
        count = max(8, int(round(2 * math.pi * radius / step)))
        for k in range(count):
            a = 2 * math.pi * k / count
            points.append((cx + radius * math.cos(a), cy + radius * math.sin(a), z_bottom + height))
    # Bottom: a disc inside the inner wall (the outer bottom sits on the pedestal).
    for radius in frange(0.0, r_inner, step):
        count = max(1, int(round(2 * math.pi * radius / step)))
        for k in range(count):
            a = 2 * math.pi * k / count
            points.append((cx + radius * math.cos(a), cy + radius * math.sin(a), z_bottom + 0.002))
    return points


def write_binary_pcd(path, points, title="window-and-cup benchmark scene (scripts/make_window_cup_scene.py)"):
    header = (
        f"# .PCD v0.7 - {title}\n"
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        f"WIDTH {len(points)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(points)}\nDATA binary\n"
    )
    temporary = path + ".tmp"
    with open(temporary, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(b"".join(struct.pack("<fff", *p) for p in points))
    os.replace(temporary, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "data", "scenes", "window_cup.pcd"))
    args = parser.parse_args()
    parts = {
        "floor": floor_points(),
        "wall 1 (window at z = 0.9)": wall_points(-1.0, 0.9),
        "wall 2 (window at z = 1.6)": wall_points(-2.2, 1.6),
        "pedestal": box_surface((-3.2, 0.0, 0.65), 0.3, 0.01),
        "cup": cup_points(-3.2, 0.0, 0.8, 0.10, 0.04, 0.035, 0.005),
    }
    points = [p for part in parts.values() for p in part]
    write_binary_pcd(args.out, points)
    for name, part in parts.items():
        print(f"  {name}: {len(part)} points")
    print(f"wrote {len(points)} points to {os.path.normpath(args.out)}")


if __name__ == "__main__":
    main()
