#!/usr/bin/env python3
"""Chung & Ooi (2011) tests 1 and 2 through `lsdem run`, against Hertz.

Runs the validation scenes (apps/scenes/validation/chung_ooi_*.toml) at 10
and 20 cells across, each with three contact settings: the grid's nodes with
the trilinear look-up (the paper's), nodes on the exact surface with the
trilinear look-up, and exact nodes with the tricubic look-up (the scenes as
shipped). From each run's tracks.csv it measures the peak contact force, the
contact duration (first to last step with a force, plus one step) and the
maximum geometric overlap (test 1: 2R minus the least centre distance; test 2:
R minus the least height of the centre above the plane), and prints a
Markdown table of their errors against the closed-form Hertz impact
(docs/accuracy.md "Chung & Ooi impacts through lsdem run").

  python3 bench/validation/chung_ooi.py --lsdem build/apps/lsdem
"""
import argparse
import csv
import math
import pathlib
import re
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "apps" / "scenes" / "validation"

# name: (dimension, radius m, E Pa, nu, rho kg/m^3, approach speed m/s, against a rigid plane)
TESTS = {
    "chung_ooi_1_3d": (3, 0.010, 48e9, 0.20, 2800.0, 10.0, False),
    "chung_ooi_2_3d": (3, 0.10, 70e9, 0.33, 2699.0, 20.475848502901393, True),
    "chung_ooi_1_2d": (2, 0.010, 48e9, 0.20, 2800.0, 10.0, False),
    "chung_ooi_2_2d": (2, 0.10, 70e9, 0.33, 2699.0, 7.476722739398317, True),
}
SETTINGS = [("grid nodes, trilinear", "grid", "trilinear"),
            ("exact nodes, trilinear", "exact_surface", "trilinear"),
            ("exact nodes, tricubic", "exact_surface", "tricubic")]


def hertz(dim, radius, e, nu, rho, speed, plane):
    """Peak overlap (m), peak force (N, N/m in 2D) and duration (s) of the Hertz impact."""
    mass = (4.0 / 3.0 * math.pi * radius**3 if dim == 3 else math.pi * radius**2) * rho
    if plane:
        m, e_star, r_star, v = mass, e / (1 - nu * nu), radius, speed
    else:
        m, e_star, r_star, v = mass / 2, e / (2 * (1 - nu * nu)), radius / 2, 2 * speed
    delta = (15 * m * v * v / (16 * e_star * math.sqrt(r_star)))**0.4
    force = 4.0 / 3.0 * e_star * math.sqrt(r_star) * delta**1.5
    # t = 2 delta/v int_0^1 (1 - x^(5/2))^(-1/2) dx = 2.9432 delta / v
    factor = 2 * 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)
    return delta, force, factor * delta / v


def measure(tracks, dim, radius, plane, dt):
    """Peak overlap, peak force and contact duration from tracks.csv."""
    rows = list(csv.DictReader(open(tracks)))
    axes = "xyz"[:dim]
    by_step = {}
    for r in rows:
        by_step.setdefault(int(r["step"]), {})[int(r["id"])] = r
    overlap, force, touching = 0.0, 0.0, []
    for step, ps in sorted(by_step.items()):
        a = ps[0]
        if plane:
            gap = float(a["y_m"]) - radius
        else:
            b = ps[1]
            gap = math.dist([float(a[k + "_m"]) for k in axes], [float(b[k + "_m"]) for k in axes]) - 2 * radius
        f = math.hypot(*[float(a["f" + k + "_N"]) for k in axes])
        overlap = max(overlap, -gap)
        force = max(force, f)
        if f > 0:
            touching.append(float(a["time_s"]))
    duration = touching[-1] - touching[0] + dt if touching else 0.0
    return overlap, force, duration


def run(lsdem, name, cells, density, nodes_on, interpolation, work):
    text = (SCENES / (name + ".toml")).read_text()
    text = re.sub(r"cells_across = \d+", "cells_across = %d" % cells, text)
    text = re.sub(r"node_density = \S+", "node_density = %g" % density, text)
    text = re.sub(r'nodes_on = "\w+"', 'nodes_on = "%s"' % nodes_on, text)
    text = re.sub(r'interpolation = "\w+"', 'interpolation = "%s"' % interpolation, text)
    dt = float(re.search(r"^dt = ([0-9.e-]+)", text, re.M).group(1))
    scene = work / ("%s_%d_%g_%s_%s.toml" % (name, cells, density, nodes_on, interpolation))
    scene.write_text(text)
    out = scene.with_suffix("")
    subprocess.run([lsdem, "run", str(scene), "--out", str(out), "--threads", "1", "-q"], check=True)
    return out / "tracks.csv", dt


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lsdem", default=str(ROOT / "build" / "apps" / "lsdem"))
    ap.add_argument("--cells", type=int, nargs="+", default=[10, 20])
    ap.add_argument("--node-density", type=float, nargs="+", default=[1, 2],
                    help="surface nodes per cell length (the scenes ship 2)")
    args = ap.parse_args()
    print("| test | cells | nodes/cell | nodes, look-up | overlap error % | peak force error % | duration error % |")
    print("| --- | ---: | ---: | --- | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        for name, (dim, radius, e, nu, rho, speed, plane) in TESTS.items():
            ref = hertz(dim, radius, e, nu, rho, speed, plane)
            for cells in args.cells:
                for density in args.node_density:
                    for label, nodes_on, interpolation in SETTINGS:
                        tracks, dt = run(args.lsdem, name, cells, density, nodes_on, interpolation, pathlib.Path(tmp))
                        got = measure(tracks, dim, radius, plane, dt)
                        err = ["%+.3f" % (100 * (g - r) / r) for g, r in zip(got, ref)]
                        print("| %s | %d | %g | %s | %s |" % (name, cells, density, label, " | ".join(err)), flush=True)


if __name__ == "__main__":
    main()
