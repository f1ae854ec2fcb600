#!/usr/bin/env python3
"""Writes the CAD assets of the demolition scene (apps/scenes/demolition/) as
ASCII STL files, in metres:

  The scene's vertical axis is y (the wall's principal axes then match the
  world's: its longest along x, its height along y, its thickness along z).

  wall.stl      a wall 1.0 m long (x), 0.6 m high (y), 0.2 m thick (z),
                standing on y = 0, centred on x = z = 0; every face split into
                a grid of triangles about 0.1 m across.
  bucket_a.stl  an excavator bucket: a curved shell (an arc of a thick ring in
  bucket_b.stl  the x-y plane, thicker at its back than at its lip) extruded
                along z, with a row of teeth on the lip. Its own origin is the
                centre of the arc. bucket_b is the same bucket, wider and with
                a tighter curve.

Every mesh is closed, consistently oriented with outward normals and free of
self-intersections (each solid is one star-shaped band or box; triangles are
oriented by checking their normal against the outward direction of their
face). Run from the repository root: python3 scripts/make_demolition_assets.py
"""

import math
import os
import sys


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


class Mesh:
    """Triangles with outward orientation enforced per triangle."""

    def __init__(self):
        self.triangles = []

    def add(self, a, b, c, outward):
        # Orient the triangle so that its normal points along `outward`.
        n = cross(sub(b, a), sub(c, a))
        if dot(n, outward) < 0.0:
            b, c = c, b
        self.triangles.append((a, b, c))

    def quad(self, a, b, c, d, outward):
        self.add(a, b, c, outward)
        self.add(a, c, d, outward)

    def write(self, path, name):
        with open(path, "w") as f:
            f.write("solid %s\n" % name)
            for a, b, c in self.triangles:
                n = cross(sub(b, a), sub(c, a))
                length = math.sqrt(dot(n, n))
                n = tuple(v / length for v in n)
                f.write("  facet normal %.9g %.9g %.9g\n    outer loop\n" % n)
                for p in (a, b, c):
                    f.write("      vertex %.9g %.9g %.9g\n" % p)
                f.write("    endloop\n  endfacet\n")
            f.write("endsolid %s\n" % name)


def box(half, centre, cell):
    """A box as a closed mesh, each face a grid of about `cell`-sized squares
    (shared edges between faces use the same divisions, so the mesh is closed)."""
    m = Mesh()
    divisions = [max(1, round(2 * h / cell)) for h in half]
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (-1.0, 1.0):
            outward = [0.0, 0.0, 0.0]
            outward[axis] = side
            for i in range(divisions[u]):
                for j in range(divisions[v]):
                    corners = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = centre[axis] + side * half[axis]
                        p[u] = centre[u] - half[u] + 2 * half[u] * (i + di) / divisions[u]
                        p[v] = centre[v] - half[v] + 2 * half[v] * (j + dj) / divisions[v]
                        corners.append(tuple(p))
                    m.quad(*corners, tuple(outward))
    return m


def bucket(radius, back_thickness, lip_thickness, width, start_deg, end_deg, teeth, segments=40):
    """An excavator bucket: the band between two arcs in the x-z plane (outer
    radius `radius`, thickness from back_thickness at start_deg to
    lip_thickness at end_deg), extruded over y in [-width/2, width/2]; `teeth`
    teeth stick out of the lip along the arc's tangent. Centre of the arc at
    the origin. (Arc coordinates are x and y; the extrusion is along z.)"""
    m = Mesh()
    hw = 0.5 * width
    # The band's outer and inner arcs, from the back to the lip.
    outer, inner, normals = [], [], []
    for k in range(segments + 1):
        s = k / segments
        t = math.radians(start_deg + (end_deg - start_deg) * s)
        r_in = radius - (back_thickness + (lip_thickness - back_thickness) * s)
        outer.append((radius * math.cos(t), radius * math.sin(t)))
        inner.append((r_in * math.cos(t), r_in * math.sin(t)))
        normals.append((math.cos(t), math.sin(t)))

    def p3(q, y):
        # Arc point q and position y across the width -> (x, y, z).
        return (q[0], q[1], y)

    # Stations across the width: the lip's teeth sit between every other pair;
    # every face along y uses the same stations, so edges meet edge to edge.
    ys = [-hw + width * i / (2 * teeth + 1) for i in range(2 * teeth + 2)]
    # Outer and inner curved faces, and the two flat sides.
    for k in range(segments):
        nk = (normals[k][0] + normals[k + 1][0], normals[k][1] + normals[k + 1][1], 0.0)
        for y0, y1 in zip(ys[:-1], ys[1:]):
            m.quad(p3(outer[k], y0), p3(outer[k + 1], y0), p3(outer[k + 1], y1), p3(outer[k], y1), nk)
            m.quad(p3(inner[k], y0), p3(inner[k + 1], y0), p3(inner[k + 1], y1), p3(inner[k], y1),
                   (-nk[0], -nk[1], 0.0))
        for y, side in ((-hw, -1.0), (hw, 1.0)):
            m.quad(p3(outer[k], y), p3(outer[k + 1], y), p3(inner[k + 1], y), p3(inner[k], y), (0.0, 0.0, side))
    # The back end: a flat face.
    tb = math.radians(start_deg)
    back_out = (math.sin(tb), -math.cos(tb), 0.0)  # against the direction of travel along the arc
    for y0, y1 in zip(ys[:-1], ys[1:]):
        m.quad(p3(outer[0], y0), p3(inner[0], y0), p3(inner[0], y1), p3(outer[0], y1), back_out)
    # The lip: flat between the teeth, each tooth a wedge along the tangent.
    tl = math.radians(end_deg)
    tangent = (-math.sin(tl), math.cos(tl))  # direction of travel along the arc at the lip
    lip_out = (tangent[0], tangent[1], 0.0)
    tooth_length = 2.0 * lip_thickness
    stations = ys
    o, n = outer[-1], inner[-1]
    for i in range(len(stations) - 1):
        y0, y1 = stations[i], stations[i + 1]
        if i % 2 == 0:
            m.quad(p3(o, y0), p3(n, y0), p3(n, y1), p3(o, y1), lip_out)
            continue
        # A tooth: a pyramid-like wedge whose tip is a segment ahead of the lip.
        mid = (0.5 * (o[0] + n[0]) + tooth_length * tangent[0], 0.5 * (o[1] + n[1]) + tooth_length * tangent[1])
        ym0, ym1 = y0 + 0.3 * (y1 - y0), y1 - 0.3 * (y1 - y0)
        tip0, tip1 = p3(mid, ym0), p3(mid, ym1)
        centre = (0.5 * (o[0] + n[0]), 0.5 * (o[1] + n[1]), 0.5 * (y0 + y1))
        # Four faces from the lip rectangle (o,y0)-(o,y1)-(n,y1)-(n,y0) to the tip segment.
        faces = [
            (p3(o, y0), p3(o, y1), tip1, tip0),
            (p3(n, y0), p3(n, y1), tip1, tip0),
        ]
        for a, b, c, d in faces:
            centre_face = tuple((a[j] + b[j] + c[j] + d[j]) / 4.0 for j in range(3))
            m.quad(a, b, c, d, sub(centre_face, centre))
        for a, b, c in ((p3(o, y0), p3(n, y0), tip0), (p3(o, y1), p3(n, y1), tip1)):
            centre_face = tuple((a[j] + b[j] + c[j]) / 3.0 for j in range(3))
            m.add(a, b, c, sub(centre_face, centre))
    return m


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = os.path.join(root, "apps", "scenes", "demolition")
    if len(sys.argv) > 1:
        out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    box((0.5, 0.3, 0.1), (0.0, 0.3, 0.0), 0.1).write(os.path.join(out, "wall.stl"), "wall")
    bucket(0.30, 0.07, 0.04, 0.40, 120.0, 330.0, 4).write(os.path.join(out, "bucket_a.stl"), "bucket_a")
    bucket(0.26, 0.07, 0.04, 0.45, 110.0, 320.0, 5).write(os.path.join(out, "bucket_b.stl"), "bucket_b")
    print("wrote wall.stl, bucket_a.stl, bucket_b.stl in", out)


if __name__ == "__main__":
    main()
