#!/usr/bin/env python3
"""Particles of the satellite-like structure of seed 003 §7.1.2 (after Simo & Tarnow):
a truncated cone (base radius 4 m, top radius 2 m, height 3 m, axis Z, base on Z = 0)
with four arms of 1 m × 1 m cross-section along ±X and ±Y, reaching 6.5 m from the axis.
The paper gives no height for the arms; here they span 1 ≤ Z ≤ 2 m, the middle third.

The particles are the centres of the dx cells of the bounding box
[−6.5, 6.5]² × [0, 3] that lie in the structure, each with volume dx³ (dx must divide
1 m, so that the arms are whole cells).

    satellite_points.py dx > points.csv
"""
import sys


def inside(x, y, z):
    r = (x * x + y * y) ** 0.5
    in_cone = r <= 4.0 - 2.0 * z / 3.0
    in_arms = 1.0 <= z <= 2.0 and (
        (abs(y) <= 0.5 and abs(x) <= 6.5) or (abs(x) <= 0.5 and abs(y) <= 6.5)
    )
    return in_cone or in_arms


def main():
    dx = float(sys.argv[1])
    n = round(1.0 / dx)
    if abs(n * dx - 1.0) > 1e-12:
        sys.exit("dx must divide 1 m")
    nxy, nz = 13 * n, 3 * n
    print("x,y,z,volume")
    for k in range(nz):
        for j in range(nxy):
            for i in range(nxy):
                x, y, z = -6.5 + (i + 0.5) * dx, -6.5 + (j + 0.5) * dx, (k + 0.5) * dx
                if inside(x, y, z):
                    print(f"{x!r},{y!r},{z!r},{dx ** 3!r}")


if __name__ == "__main__":
    main()
