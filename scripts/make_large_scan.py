#!/usr/bin/env python3
"""Writes a large scan for the scaling figures of docs/benchmark.md: the
window-and-cup scene plus uniformly random points of a 2 cm thick floor layer
(x in [-4.5, 1.5], y in [-2.5, 2.5], z in [0, 0.02]) up to --points in all,
as a binary PCD with float64 x, y, z (the type many sensor drivers write).
Deterministic for a given --seed.

Usage: /usr/bin/python3 scripts/make_large_scan.py --out /tmp/big.pcd [--points 5000000] [--seed 1]
"""
import argparse
import re

import numpy as np


def read_scene(path):
    raw = open(path, "rb").read()
    data_at = raw.index(b"\nDATA ") + 1
    header = raw[:data_at].decode()
    line_end = raw.index(b"\n", data_at)
    kind = raw[data_at:line_end].decode().split()[1]
    if kind != "binary":
        raise SystemExit(f"{path}: expected a binary PCD (got DATA {kind})")
    fields = re.search(r"^FIELDS (.*)$", header, re.M).group(1).split()
    sizes = re.search(r"^SIZE (.*)$", header, re.M).group(1).split()
    types = re.search(r"^TYPE (.*)$", header, re.M).group(1).split()
    count = int(re.search(r"^POINTS (\d+)$", header, re.M).group(1))
    dtype = np.dtype([(f, "<" + {"F": "f", "I": "i", "U": "u"}[t] + s) for f, s, t in zip(fields, sizes, types)])
    cloud = np.frombuffer(raw[line_end + 1:line_end + 1 + count * dtype.itemsize], dtype=dtype)
    return np.stack([cloud["x"], cloud["y"], cloud["z"]], axis=1).astype(np.float64)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--points", type=int, default=5_000_000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--scene", default="data/scenes/window_cup.pcd")
    args = parser.parse_args()
    scene = read_scene(args.scene)
    extra = args.points - len(scene)
    if extra < 0:
        raise SystemExit(f"--points must be at least the scene's {len(scene)}")
    rng = np.random.default_rng(args.seed)
    floor = np.stack([rng.uniform(-4.5, 1.5, extra), rng.uniform(-2.5, 2.5, extra), rng.uniform(0.0, 0.02, extra)], 1)
    points = np.concatenate([scene, floor]).astype("<f8")
    header = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
              f"WIDTH {len(points)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(points)}\nDATA binary\n")
    with open(args.out, "wb") as out:
        out.write(header.encode() + points.tobytes())
    print(f"{args.out}: {len(points)} points ({len(scene)} from {args.scene})")


if __name__ == "__main__":
    main()
