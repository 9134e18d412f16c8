#!/usr/bin/env python3
"""Particles at the nodes of a hexahedral mesh, as seed 004 builds its particle clouds from
finite-element meshes (§6.4, Fig. 12(b)): one particle at each node, with the volumes of
the elements around it averaged to it (an eighth of each).

The mesh is an nx × ny × nz grid of spacing dx from (x0, y0, z0) whose interior nodes are
moved by independent uniform offsets in [−a dx, a dx] per component (seeded, so the output
is reproducible); nodes on the faces stay on the grid, so that the faces stay plane and
the regions of a box's boundary conditions still select them. a = 0 gives the vertex
lattice with tributary volumes. An element's volume is the integral of det J of its
trilinear map, exact with 2 × 2 × 2 Gauss points.

    hex_mesh_points.py nx ny nz dx a seed [x0 y0 z0] > points.csv

The paper's clouds are unpublished: these are stand-ins with its construction.
"""
import itertools
import random
import sys

CORNERS = [(i, j, k) for k in (0, 1) for j in (0, 1) for i in (0, 1)]


def volume(p):
    """The volume of the trilinear hexahedron with corners p in CORNERS order."""
    g = 3 ** -0.5
    total = 0.0
    for xi in itertools.product((-g, g), repeat=3):
        jac = [[0.0] * 3 for _ in range(3)]
        for corner, x in zip(CORNERS, p):
            s = [2 * c - 1 for c in corner]
            n = [(1 + s[m] * xi[m]) / 2 for m in range(3)]
            dn = [s[0] / 2 * n[1] * n[2], s[1] / 2 * n[0] * n[2], s[2] / 2 * n[0] * n[1]]
            for r in range(3):
                for m in range(3):
                    jac[r][m] += x[r] * dn[m]
        (a, b, c), (d, e, f), (g_, h, i) = jac
        total += a * (e * i - f * h) - b * (d * i - f * g_) + c * (d * h - e * g_)
    return total


def main():
    nx, ny, nz = (int(v) for v in sys.argv[1:4])
    dx, a, seed = float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
    origin = [float(v) for v in sys.argv[7:10]] if len(sys.argv) > 9 else [0.0] * 3
    rng = random.Random(seed)
    nodes = {}
    for k in range(nz + 1):
        for j in range(ny + 1):
            for i in range(nx + 1):
                x = [origin[0] + i * dx, origin[1] + j * dx, origin[2] + k * dx]
                if 0 < i < nx and 0 < j < ny and 0 < k < nz:
                    x = [c + a * dx * (2.0 * rng.random() - 1.0) for c in x]
                nodes[i, j, k] = x
    share = {key: 0.0 for key in nodes}
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                corners = [(i + di, j + dj, k + dk) for di, dj, dk in CORNERS]
                v = volume([nodes[c] for c in corners])
                for c in corners:
                    share[c] += v / 8
    print("x,y,z,volume")
    for k in range(nz + 1):
        for j in range(ny + 1):
            for i in range(nx + 1):
                x, y, z = nodes[i, j, k]
                print(f"{x:.12e},{y:.12e},{z:.12e},{share[i, j, k]:.12e}")


main()
