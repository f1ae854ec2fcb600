#!/usr/bin/env python3
"""Writes the example labelled volume of the ct_grains scene
(apps/scenes/ct_grains/ct_grains.nrrd): a synthetic "segmented CT scan" of
sand-like grains, as a gzip NRRD of 8-bit labels.

  64 x 64 x 48 voxels of 0.05 mm (3.2 x 3.2 x 2.4 mm), origin (the centre of
  the first voxel) at (0.025, 0.025, 0.025) mm: "space directions" and
  "space origin" are in millimetres (`lsdem ct2ls --scale 0.001`).

  Labels 1-6: grains 0.8-1.1 mm long (16-22 voxels), each a turned ellipsoid
  with a bumpy surface r(u) = 1 + 0.06 sin(3 a) cos(2 b) in its own frame,
  placed without touching one another.
  Label 7: a grain cut off by the x = 0 face of the image (ct2ls skips it).
  Label 8: a speck of 12 voxels (below ct2ls's --min-voxels 100, skipped).

A voxel belongs to a grain when its centre is inside. Pure Python (no numpy),
deterministic (seed 7). Run from the repository root:
python3 scripts/make_ct_example.py [OUT.nrrd]
"""

import gzip
import math
import random
import sys

NX, NY, NZ = 64, 64, 48
VOXEL_MM = 0.05


def rotation(rng):
    """A random rotation matrix (rows), from a random unit quaternion."""
    q = [rng.gauss(0.0, 1.0) for _ in range(4)]
    n = math.sqrt(sum(c * c for c in q))
    w, x, y, z = (c / n for c in q)
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def make_grain(centre, axes, rot):
    """Inside test of a bumpy turned ellipsoid (voxel units)."""

    def inside(p):
        d = [p[i] - centre[i] for i in range(3)]
        # Into the grain's frame: R^T d, scaled by the semi-axes.
        u = [sum(rot[r][c] * d[r] for r in range(3)) / axes[c] for c in range(3)]
        rr = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        if rr == 0.0:
            return True
        a = math.atan2(u[1], u[0])
        b = math.acos(max(-1.0, min(1.0, u[2] / rr)))
        return rr < 1.0 + 0.06 * math.sin(3 * a) * math.cos(2 * b)

    reach = max(axes) * 1.07
    return inside, centre, reach


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "apps/scenes/ct_grains/ct_grains.nrrd"
    rng = random.Random(7)
    grains = []
    # Six grains inside, not touching each other or the border.
    while len(grains) < 6:
        axes = [rng.uniform(8.0, 11.0), rng.uniform(6.5, 8.5), rng.uniform(5.5, 7.0)]
        reach = max(axes) * 1.07
        centre = [rng.uniform(reach + 2, n - 3 - reach) for n in (NX, NY, NZ)]
        if any(math.dist(centre, g[1]) < reach + g[2] + 2.0 for g in grains):
            continue
        grains.append(make_grain(centre, axes, rotation(rng)))
    labels = bytearray(NX * NY * NZ)
    for k in range(NZ):
        for j in range(NY):
            for i in range(NX):
                p = (i, j, k)
                for label, (inside, centre, reach) in enumerate(grains, start=1):
                    if abs(i - centre[0]) < reach and abs(j - centre[1]) < reach and abs(k - centre[2]) < reach:
                        if inside(p):
                            labels[i + NX * (j + NY * k)] = label
    # Label 7: a grain cut by the x = 0 face (where no grain of the six is).
    for k in range(NZ):
        for j in range(NY):
            for i in range(NX):
                v = i + NX * (j + NY * k)
                if labels[v] == 0 and (i + 3) ** 2 / 49.0 + (j - 32) ** 2 / 36.0 + (k - 8) ** 2 / 25.0 < 1.0:
                    labels[v] = 7
    # Label 8: a speck of 12 voxels.
    for k in range(40, 42):
        for j in range(2, 4):
            for i in range(60, 63):
                v = i + NX * (j + NY * k)
                if labels[v] == 0:
                    labels[v] = 8
    h = VOXEL_MM
    header = (
        "NRRD0004\n"
        "# ct_grains example: synthetic labelled volume (scripts/make_ct_example.py)\n"
        "type: uint8\ndimension: 3\nspace: 3D-right-handed\n"
        f"sizes: {NX} {NY} {NZ}\n"
        f"space directions: ({h},0,0) (0,{h},0) (0,0,{h})\n"
        "space units: \"mm\" \"mm\" \"mm\"\n"
        "kinds: domain domain domain\nencoding: gzip\n"
        f"space origin: ({h / 2},{h / 2},{h / 2})\n\n"
    )
    with open(out, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(gzip.compress(bytes(labels), compresslevel=9, mtime=0))
    counts = {}
    for v in labels:
        counts[v] = counts.get(v, 0) + 1
    print(out, {k: counts[k] for k in sorted(counts) if k})


if __name__ == "__main__":
    main()
