#!/usr/bin/env python3
"""Crush three grains between a floor and a moving platen from Python, and
plot the particle size distribution before and after.

The scene is the shipped three-grains test (paper Fig. 5, 2D), read as a dict
and built with lsdem.Scene.from_dict, so a script can change any key first
(here the duration). A callback reports each breakage as it happens. The size
distribution is by mass against sieve size (eq. 21), fines removed by breakage
counted at their own size, as psd.csv has it. With matplotlib the two curves
go to a PNG; without it they are printed as a table.

    PYTHONPATH=build/python python3 examples/python/crush.py
    python3 examples/python/crush.py --duration 0.04 --plot psd.png
"""

import argparse
import pathlib
import sys
import tomllib

import numpy as np

import lsdem

HERE = pathlib.Path(__file__).resolve().parent
# In the source tree, and where cmake --install puts the examples and scenes.
CANDIDATES = [
    HERE.parents[1] / "apps" / "scenes" / "three_grains" / "three_grains_2d.toml",
    HERE.parent / "three_grains" / "three_grains_2d.toml",
]


def size_distribution(sim):
    """(sieve sizes in m, percent of the mass passing), fines included."""
    sizes = list(sim.sieve_sizes())
    masses = list(sim.true_masses())
    for r in sim.removed():
        if r["reason"] == "fines":
            sizes.append(r["sieve_size"])
            masses.append(r["mass"])
    order = np.argsort(sizes, kind="stable")
    sizes = np.asarray(sizes)[order]
    passing = 100.0 * np.cumsum(np.asarray(masses)[order]) / np.sum(masses)
    return sizes, passing


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", type=pathlib.Path, help="a 2D or 3D crushing scene (default: three grains 2D)")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the scene's)")
    parser.add_argument("--threads", type=int, default=1, help="OpenMP threads (0: all cores)")
    parser.add_argument("--plot", type=pathlib.Path, default=pathlib.Path("crush_psd.png"), help="PNG to write")
    args = parser.parse_args()

    path = args.scene or next((c for c in CANDIDATES if c.is_file()), None)
    if path is None:
        sys.exit("crush.py: three_grains_2d.toml not found; give --scene")
    with open(path, "rb") as f:
        scene_dict = tomllib.load(f)
    if args.duration is not None:
        scene_dict["simulation"].pop("steps", None)
        scene_dict["simulation"]["duration"] = args.duration
    scene = lsdem.Scene.from_dict(scene_dict)
    duration = scene.duration

    sim = lsdem.Simulation(scene, threads=args.threads)
    before = size_distribution(sim)
    print(f"{path.name}: {len(sim)} particles, dt {sim.dt:.3g} s, {duration} s to simulate")

    seen = 0

    def report(s):
        nonlocal seen
        log = s.breakage_log()
        for event in log[seen:]:
            print(f"  t = {event['time'] * 1e3:7.3f} ms: particle {event['parent']} -> {event['children']}"
                  f" (sigma {event['criterion_value'] / 1e3:.1f} kPa, strength {event['strength'] / 1e3:.1f} kPa)")
        seen = len(log)
        return s.time < duration  # False stops step() at the end

    sim.add_callback(report)
    if scene.steps > 0:
        sim.step(scene.steps)
    else:
        while sim.step(100_000) == 100_000:
            pass
    after = size_distribution(sim)
    fines = sum(r["mass"] for r in sim.removed() if r["reason"] == "fines")
    print(f"{sim.steps} steps in {sim.wall_seconds:.1f} s: {len(sim.breakage_log())} breakages, "
          f"{len(sim)} particles, fines {100 * fines / (fines + sim.true_masses().sum()):.1f} % of the mass")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: the size distributions as a table")
        for name, (sizes, passing) in (("before", before), ("after", after)):
            print(f"{name}:\n  sieve size (mm)  passing (%)")
            for d, p in zip(sizes, passing):
                print(f"  {d * 1e3:14.4f}  {p:11.2f}")
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, (sizes, passing) in (("before", before), ("after", after)):
        ax.step(sizes * 1e3, passing, where="post", label=f"{name} ({len(sizes)} pieces incl. fines)")
    ax.set_xscale("log")
    ax.set_xlabel("sieve size (mm)")
    ax.set_ylabel("mass passing (%)")
    ax.set_title(f"{path.stem}: particle size distribution")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.plot, dpi=120)
    print(f"size distributions plotted in {args.plot}")


if __name__ == "__main__":
    main()
