#!/usr/bin/env python3
"""Writes an icosphere (a subdivided icosahedron projected on a sphere) as an OBJ surface mesh.

    python3 assets/meshes/make_icosphere.py [levels] [radius] > assets/meshes/icosphere.obj

Each level splits every triangle into 4; level 2 gives 162 vertices and 320 triangles. The
triangles are wound counter-clockwise seen from outside (outward normals).
"""
import math
import sys


def icosphere(levels, radius):
    p = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p),
             (0, -1, -p), (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]
    tris = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
            (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
            (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                verts.append(tuple((x + y) / 2 for x, y in zip(verts[a], verts[b])))
                middle[key] = len(verts) - 1
            return middle[key]

        refined = []
        for a, b, c in tris:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        tris = refined
    scaled = []
    for v in verts:
        n = math.sqrt(sum(x * x for x in v))
        scaled.append(tuple(radius * x / n for x in v))
    return scaled, tris


def main():
    levels = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    radius = float(sys.argv[2]) if len(sys.argv) > 2 else 0.1
    verts, tris = icosphere(levels, radius)
    out = sys.stdout
    out.write(f"# icosphere: {levels} subdivisions, radius {radius} m, "
              f"{len(verts)} vertices, {len(tris)} triangles (make_icosphere.py)\n")
    for v in verts:
        out.write("v %.9f %.9f %.9f\n" % v)
    for a, b, c in tris:
        out.write(f"f {a + 1} {b + 1} {c + 1}\n")


if __name__ == "__main__":
    main()
