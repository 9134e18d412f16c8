#!/usr/bin/env python3
"""Particles from a quadrilateral mesh, as seed 004 §6.2 and §6.5 build them: one particle
at the centroid of each element, with the element's area as its volume.

The mesh is an nx × ny grid of spacing dx on [x0, x0 + nx dx] × [y0, y0 + ny dx] whose
interior nodes are moved by independent uniform offsets in [−a dx, a dx] per component
(seeded, so the output is reproducible); boundary nodes stay on the grid, so every
element on an edge has an edge dx long. a = 0 gives the regular cell-centred lattice.

    quad_mesh_points.py nx ny dx a seed [x0 y0] > points.csv

The paper's meshes are unpublished (Figs 4 and 17 survive only as captions): these are
stand-ins with the same construction.
"""
import random
import sys


def main():
    nx, ny = int(sys.argv[1]), int(sys.argv[2])
    dx, a, seed = float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
    x0, y0 = (float(sys.argv[6]), float(sys.argv[7])) if len(sys.argv) > 7 else (0.0, 0.0)
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
    for j in range(ny):
        for i in range(nx):
            p = [nodes[i, j], nodes[i + 1, j], nodes[i + 1, j + 1], nodes[i, j + 1]]
            area = cx = cy = 0.0
            for k in range(4):
                (xa, ya), (xb, yb) = p[k], p[(k + 1) % 4]
                c = xa * yb - xb * ya
                area += c
                cx += (xa + xb) * c
                cy += (ya + yb) * c
            area *= 0.5
            print(f"{cx / (6 * area):.12e},{cy / (6 * area):.12e},{area:.12e}")


main()
