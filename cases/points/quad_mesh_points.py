#!/usr/bin/env python3
"""Particles from a quadrilateral mesh, as seed 004 §6.2 and §6.5 build them: one particle
at the centroid of each element, with the element's area as its volume; or, with
`--nodes`, as its §6.4 does (Fig. 12(b)): one particle at each node of the mesh, with the
areas of the elements around it averaged to it (a quarter of each).

The mesh is an nx × ny grid of spacing dx on [x0, x0 + nx dx] × [y0, y0 + ny dx] whose
interior nodes are moved by independent uniform offsets in [−a dx, a dx] per component
(seeded, so the output is reproducible); boundary nodes stay on the grid, so every
element on an edge has an edge dx long. a = 0 gives the regular cell-centred lattice.

    quad_mesh_points.py [--nodes] nx ny dx a seed [x0 y0] > points.csv

The paper's meshes are unpublished (Figs 4 and 17 survive only as captions): these are
stand-ins with the same construction.
"""
import random
import sys


def area_and_centroid(p):
    """The area and centroid of the quadrilateral with corners p (counter-clockwise)."""
    area = cx = cy = 0.0
    for k in range(4):
        (xa, ya), (xb, yb) = p[k], p[(k + 1) % 4]
        c = xa * yb - xb * ya
        area += c
        cx += (xa + xb) * c
        cy += (ya + yb) * c
    area *= 0.5
    return area, cx / (6 * area), cy / (6 * area)


def main():
    args = sys.argv[1:]
    at_nodes = args[:1] == ["--nodes"]
    if at_nodes:
        args = args[1:]
    nx, ny = int(args[0]), int(args[1])
    dx, a, seed = float(args[2]), float(args[3]), int(args[4])
    x0, y0 = (float(args[5]), float(args[6])) if len(args) > 6 else (0.0, 0.0)
    rng = random.Random(seed)
    nodes = {}
    for j in range(ny + 1):
        for i in range(nx + 1):
            x, y = x0 + i * dx, y0 + j * dx
            if 0 < i < nx and 0 < j < ny:
                x += a * dx * (2.0 * rng.random() - 1.0)
                y += a * dx * (2.0 * rng.random() - 1.0)
            nodes[i, j] = (x, y)
    print("x,y,volume")
    share = {key: 0.0 for key in nodes}
    for j in range(ny):
        for i in range(nx):
            corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            area, cx, cy = area_and_centroid([nodes[c] for c in corners])
            if at_nodes:
                for c in corners:
                    share[c] += area / 4
            else:
                print(f"{cx:.12e},{cy:.12e},{area:.12e}")
    if at_nodes:
        for j in range(ny + 1):
            for i in range(nx + 1):
                (x, y), v = nodes[i, j], share[i, j]
                print(f"{x:.12e},{y:.12e},{v:.12e}")


main()
