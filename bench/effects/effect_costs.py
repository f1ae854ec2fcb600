#!/usr/bin/env python3
"""What each declared effect and recorder costs per step (README "Cost by effect").

Runs a shipped scene as it is and with one effect or output left out at a time,
each `--repeats` times for `--steps` steps on one thread, and prints a Markdown
table: ms per step (median wall time of the run over its steps, set-up
included), the difference to the scene as shipped, and for effects the seconds
the world itself measured for them (summary.json `effects`, and the energy
ledger's `stage_seconds.energy`). An effect or output the scene does not
declare is not built: leaving it out removes its whole cost. Leaving out an
output or the energy ledger leaves the motion as it is, so the difference is
that output's cost; leaving out gravity, damping, breakage or the outflow
changes the motion, so there the measured seconds inside the step are the
effect's cost.

  python3 bench/effects/effect_costs.py --lsdem build/apps/lsdem \
      apps/scenes/oedometer/oedometer_2d.toml --steps 20000
"""
import argparse
import json
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile


def sections(text):
    """(header, lines) blocks of a TOML file, in order; the first header is ''."""
    out = [["", []]]
    for line in text.splitlines():
        if re.match(r"^\s*\[", line):
            out.append([line.strip(), []])
        out[-1][1].append(line)
    return out


def join(blocks):
    return "\n".join(line for _, lines in blocks for line in lines) + "\n"


def without_key(text, section, key):
    blocks = sections(text)
    for header, lines in blocks:
        if header == f"[{section}]":
            lines[:] = [l for l in lines if not re.match(rf"^\s*{re.escape(key)}\s*=", l)]
    return join(blocks)


def with_key(text, section, key, value):
    blocks = sections(text)
    for header, lines in blocks:
        if header == f"[{section}]":
            lines[:] = [l for l in lines if not re.match(rf"^\s*{re.escape(key)}\s*=", l)]
            lines.insert(1, f"{key} = {value}")
    return join(blocks)


def without_section(text, section):
    """Drops [section] and its sub-tables."""
    blocks = sections(text)
    keep = [b for b in blocks if not re.match(rf"^\[\[?{re.escape(section)}([.\]])", b[0])]
    return join(keep)


def has_key(text, section, key):
    return any(h == f"[{section}]" and any(re.match(rf"^\s*{re.escape(key)}\s*=", l) for l in lines)
               for h, lines in sections(text))


def has_section(text, section):
    return any(h == f"[{section}]" for h, _ in sections(text))


def variants(text):
    """(what is left out, scene text) for each optional part the scene declares."""
    out = [("nothing (the scene as shipped)", text)]
    for key in ("gravity", "global_damping", "local_damping", "outflow"):
        if has_key(text, "effects", key):
            # the discharge classifies what the outflow removes: it goes too
            variant = without_key(text, "effects", key)
            out.append((f"effect `{key}`", without_key(variant, "effects", "discharge") if key == "outflow" else variant))
    if has_section(text, "effects.breakage.chipping"):
        out.append(("chipping (`[effects.breakage.chipping]`)", without_section(text, "effects.breakage.chipping")))
    if has_section(text, "effects.breakage"):
        out.append(("effect `breakage`", without_section(text, "effects.breakage")))
    if has_section(text, "effects"):
        out.append(("the energy ledger (`energy_ledger = false`)", with_key(text, "effects", "energy_ledger", "false")))
    if has_key(text, "output", "frames"):
        out.append(("ParaView frames (`frames = 0`)", with_key(text, "output", "frames", "0")))
    out.append(("history rows between first and last (`history_rows = 0`)",
                with_key(text, "output", "history_rows", "0")))
    dist = without_key(text, "output", "distribution_times")
    out.append(("distributions between first and last (`distributions = 0`)",
                with_key(dist, "output", "distributions", "0")))
    if has_key(text, "output", "checkpoint_every"):
        out.append(("periodic checkpoints (`checkpoint_every = 0`)", without_key(text, "output", "checkpoint_every")))
    bare = text
    for key in ("global_damping", "local_damping"):
        bare = without_key(bare, "effects", key)
    bare = without_section(bare, "effects.breakage")
    bare = with_key(bare, "effects", "energy_ledger", "false")
    for key, value in (("frames", "0"), ("history_rows", "0"), ("distributions", "0")):
        bare = with_key(bare, "output", key, value)
    bare = without_key(without_key(bare, "output", "distribution_times"), "output", "checkpoint_every")
    out.append(("all of the above (gravity and outflow kept)", bare))
    return out


def run(lsdem, scene, out, steps):
    subprocess.run([lsdem, "run", str(scene), "--out", str(out), "--steps", str(steps), "--threads", "1", "-q",
                    "--overwrite"], check=True, stdout=subprocess.DEVNULL)
    s = json.loads((out / "summary.json").read_text())
    effects = {e["name"]: e["seconds"] for e in s.get("effects", [])}
    return s["wall_time"] / s["steps"], effects, s["steps"], s["stage_seconds"].get("energy", 0.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--lsdem", default="build/apps/lsdem")
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    scene = pathlib.Path(a.scene).resolve()
    text = scene.read_text()
    with tempfile.TemporaryDirectory(prefix="lsdem_effect_costs_") as tmp:
        work = pathlib.Path(tmp) / "scene"
        shutil.copytree(scene.parent, work)  # the scene's own files (meshes, grains) beside it
        rows = []
        base = None
        for what, variant in variants(text):
            path = work / ("variant_" + scene.name)
            path.write_text(variant)
            times, effects, energy = [], {}, []
            for r in range(a.repeats):
                t, effects, steps, e = run(a.lsdem, path, pathlib.Path(tmp) / "out", a.steps)
                times.append(t)
                energy.append(e / steps)
            ms = 1e3 * statistics.median(times)
            if base is None:
                base = (ms, effects, 1e3 * statistics.median(energy))
            rows.append((what, ms))
            print(f"  {what}: {ms:.4f} ms/step", file=sys.stderr)
    ms0, effects0, energy0 = base
    print(f"Scene `{scene.name}`, {a.steps} steps, 1 thread, median of {a.repeats} runs.\n")
    print("| left out | ms/step | change |")
    print("| --- | ---: | ---: |")
    for what, ms in rows:
        print(f"| {what} | {ms:.3f} | {100.0 * (ms - ms0) / ms0:+.1f}% |")
    print("\nMeasured inside the step of the scene as shipped (ms/step, share of the step):\n")
    print("| part | ms/step | share |")
    print("| --- | ---: | ---: |")
    for name, seconds in effects0.items():
        per = 1e3 * seconds / a.steps
        print(f"| effect `{name}` | {per:.4f} | {100.0 * per / ms0:.2f}% |")
    print(f"| energy ledger (stage `energy`) | {energy0:.4f} | {100.0 * energy0 / ms0:.2f}% |")


if __name__ == "__main__":
    main()
