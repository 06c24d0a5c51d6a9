#!/usr/bin/env python3
"""Writes a benchmark robot the way CAD exporters write them: the second
example robot (meshes/longarm) with every arm link's primitive collision
elements replaced by finely tessellated binary STL meshes, 2 to 4 meshes per
link, N triangles in all (default 400,000), and the defects exporters leave:
a face written twice with the second copy reversed, and a face written twice
the same way. The airframe stays URDF primitives.

It exists to measure quadhand-sdfgen and the per-plan loading on a robot of
the size real exports have (docs/benchmark.md, "Large CAD meshes"); the test
suite's own CAD-export robot is tests/data/cad_robot.

  python3 scripts/make_cad_arm.py --out /tmp/cad_arm [--triangles 400000]

Writes OUT/cad_longarm.urdf, its STL files and the gripper palm (Collada),
and OUT/cad_longarm_cup.yaml: data/tasks/longarm_cup.yaml for this robot
(its sdf_dir is OUT/sdf).
"""
import argparse
import math
import os
import re
import shutil
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
LONGARM = os.path.join(ROOT, "meshes", "longarm")


def write_stl(path, triangles):
    out = bytearray(b"QuadHand make_cad_arm.py benchmark mesh".ljust(80, b" "))
    out += struct.pack("<I", len(triangles))
    for t in triangles:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for v in t:
            out += struct.pack("<3f", *v)
        out += struct.pack("<H", 0)
    with open(path, "wb") as f:
        f.write(bytes(out))


def uv_sphere(radius, rings, segments, center=(0.0, 0.0, 0.0)):
    cx, cy, cz = center
    def point(i, j):
        theta = math.pi * i / rings
        phi = 2.0 * math.pi * j / segments
        return (cx + radius * math.sin(theta) * math.cos(phi), cy + radius * math.sin(theta) * math.sin(phi),
                cz + radius * math.cos(theta))
    tris = []
    for i in range(rings):
        for j in range(segments):
            a, b = point(i, j), point(i, j + 1)
            c, d = point(i + 1, j), point(i + 1, j + 1)
            if i != 0:
                tris.append([a, c, b])
            if i != rings - 1:
                tris.append([b, c, d])
    return tris


def cylinder_z(radius, length, segments, rings=1, center=(0.0, 0.0, 0.0)):
    """Axis z: side strips in `rings` bands and fan caps, as exporters tessellate."""
    cx, cy, cz = center
    lo = cz - 0.5 * length
    rim = [(cx + radius * math.cos(2 * math.pi * k / segments), cy + radius * math.sin(2 * math.pi * k / segments))
           for k in range(segments)]
    zs = [lo + length * r / rings for r in range(rings + 1)]
    tris = []
    for k in range(segments):
        (x0, y0), (x1, y1) = rim[k], rim[(k + 1) % segments]
        for r in range(rings):
            za, zb = zs[r], zs[r + 1]
            tris.append([(x0, y0, za), (x1, y1, za), (x1, y1, zb)])
            tris.append([(x0, y0, za), (x1, y1, zb), (x0, y0, zb)])
        tris.append([(cx, cy, zs[-1]), (x0, y0, zs[-1]), (x1, y1, zs[-1])])
        tris.append([(cx, cy, lo), (x1, y1, lo), (x0, y0, lo)])
    return tris


def torus_z(major, minor, segments, tube_segments, center=(0.0, 0.0, 0.0)):
    cx, cy, cz = center
    def point(i, j):
        u = 2 * math.pi * i / segments
        v = 2 * math.pi * j / tube_segments
        r = major + minor * math.cos(v)
        return (cx + r * math.cos(u), cy + r * math.sin(u), cz + minor * math.sin(v))
    tris = []
    for i in range(segments):
        for j in range(tube_segments):
            a, b = point(i, j), point(i + 1, j)
            c, d = point(i, j + 1), point(i + 1, j + 1)
            tris.append([a, b, d])
            tris.append([a, d, c])
    return tris


def box(size, center=(0.0, 0.0, 0.0)):
    hx, hy, hz = (0.5 * s for s in size)
    cx, cy, cz = center
    corners = [(cx + sx * hx, cy + sy * hy, cz + sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = []
    for a, b, c, d in quads:
        tris.append([corners[a], corners[b], corners[c]])
        tris.append([corners[a], corners[c], corners[d]])
    return tris


def rotate_to_x(tris):
    """Axis z to axis x (a quarter turn about y), for parts along the link."""
    return [[(z, y, -x) for (x, y, z) in t] for t in tris]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="output folder (created)")
    parser.add_argument("--triangles", type=int, default=400000, help="about this many triangles in all")
    args = parser.parse_args()
    if args.triangles < 2000:
        sys.exit("make_cad_arm.py: --triangles must be at least 2000")
    os.makedirs(args.out, exist_ok=True)

    # Curved parts share the budget: 10 % per ball, 10 % per long cylinder,
    # 20 % per torus (a fillet ring). Circles have 256 segments, as a fine
    # export has: more triangles come from more bands, not from wider fans.
    n = args.triangles
    segments = 256
    def bands(weight):  # bands of a 256-segment cylinder with `weight` of the budget
        return max(1, int(n * weight / (2 * segments)))
    s_sphere = max(8, int(math.sqrt(n * 0.10)))  # rings = segments / 2: s^2 triangles
    s_torus = max(8, int(math.sqrt(n * 0.20 / 2)))  # 2 s x s / 2 rings x segments, 2 triangles each
    def along_x(tris, dx=0.0):
        return [[(x + dx, y, z) for (x, y, z) in t] for t in rotate_to_x(tris)]
    bolts = []  # a bolt pattern: 8 separate closed shells in one file
    for b in range(8):
        bolts += cylinder_z(0.004, 0.03, 64, 1, (0.03 + 0.028 * b, 0.0, 0.0))
    parts = {
        "upper_arm": [
            ("shoulder_ball", uv_sphere(0.025, s_sphere // 2, s_sphere)),
            ("upper_tube", along_x(cylinder_z(0.016, 0.3, segments, bands(0.10)), 0.15)),
            ("shoulder_ring", torus_z(0.018, 0.006, 2 * s_torus, s_torus // 2)),
        ],
        "forearm": [
            ("forearm_beam", box((0.26, 0.028, 0.028), (0.13, 0.0, 0.0))),
            ("elbow_motor", cylinder_z(0.013, 0.026, segments, bands(0.10))),
            ("forearm_ball", uv_sphere(0.013, s_sphere // 2, s_sphere, (0.26, 0.0, 0.0))),
            ("forearm_bolts", bolts),
        ],
        "wrist": [
            ("wrist_tube", along_x(cylinder_z(0.018, 0.05, segments, bands(0.10)), 0.025)),
            ("wrist_ball", uv_sphere(0.017, s_sphere // 2, s_sphere)),
        ],
        "gripper": [
            ("finger_left", box((0.08, 0.01, 0.02), (0.08, 0.085, 0.0))),
            ("finger_right", box((0.08, 0.01, 0.02), (0.08, -0.085, 0.0))),
            ("finger_roller", torus_z(0.004, 0.0035, 2 * s_torus, s_torus // 2, (0.04, 0.0, 0.0))),
        ],
    }
    # The defects: one face again reversed (a zero-volume fin), one face twice.
    tube = parts["upper_arm"][1][1]
    tube.append([tube[5][0], tube[5][2], tube[5][1]])
    beam = parts["forearm"][0][1]
    beam.append(list(beam[3]))

    total = 0
    elements = {}
    for link, meshes in parts.items():
        elements[link] = []
        for name, tris in meshes:
            write_stl(os.path.join(args.out, name + ".stl"), tris)
            elements[link].append(name + ".stl")
            total += len(tris)

    urdf = open(os.path.join(LONGARM, "longarm.urdf")).read()
    for link, files in elements.items():
        block = re.search(r'(<link name="%s">.*?</link>)' % link, urdf, re.S).group(1)
        keep = [c for c in re.findall(r"<collision>.*?</collision>", block, re.S) if "<mesh" in c]
        new_collisions = keep + ['<collision><geometry><mesh filename="%s"/></geometry></collision>' % f for f in files]
        body = re.sub(r"\s*<collision>.*?</collision>", "", block, flags=re.S)
        body = body.replace("</link>", "\n    " + "\n    ".join(new_collisions) + "\n  </link>")
        urdf = urdf.replace(block, body)
    urdf = urdf.replace("package://longarm/gripper_palm.dae", "gripper_palm.dae")
    urdf = urdf.replace('<robot name="longarm">', '<robot name="cad_longarm">', 1)
    urdf = urdf.replace("<!--", "<!-- Written by scripts/make_cad_arm.py from meshes/longarm/longarm.urdf:\n"
                        "     arm links as CAD-export meshes (%d triangles).\n" % total, 1)
    open(os.path.join(args.out, "cad_longarm.urdf"), "w").write(urdf)
    shutil.copy(os.path.join(LONGARM, "gripper_palm.dae"), args.out)

    task = open(os.path.join(ROOT, "data", "tasks", "longarm_cup.yaml")).read()
    task = re.sub(r"(?m)^robot:.*$", "robot: cad_longarm.urdf", task)
    task = re.sub(r"(?m)^sdf_dir:.*$", "sdf_dir: sdf", task)
    task = re.sub(r"(?m)^scene:.*$", "scene: %s" % os.path.join(ROOT, "data", "scenes", "window_cup.pcd"), task)
    open(os.path.join(args.out, "cad_longarm_cup.yaml"), "w").write(task)
    print("make_cad_arm.py: wrote %s/cad_longarm.urdf: %d triangles in %d meshes"
          % (args.out, total, sum(len(f) for f in elements.values())))


if __name__ == "__main__":
    main()
