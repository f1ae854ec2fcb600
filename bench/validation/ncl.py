#!/usr/bin/env python3
"""Slope of the normal compression line (NCL) of lsdem oedometer runs against
McDowell & de Bono (2013): log e = log e_y - (1 / (2 b)) log(sigma / sigma_y),
with the size effect on mean particle strength sigma_av ~ d^-b; for Weibull
strengths with the volume size effect (lsdem eq. 11-13) b = 3 / m, so the
slope -d log e / d log sigma is m / 6 (docs/validation.md).

Usage:
  python3 bench/validation/ncl.py [--out DIR] [--plot PNG] RUN=SCENE.toml ...
  python3 bench/validation/ncl.py --self-test

Each RUN is an `lsdem run` output folder (history.csv, removed.csv,
summary.json) of a scene with [output.specimen]; SCENE is its scene file
(read for [contact] friction_from, the test's start, the Weibull modulus, the
density and the specimen area). Pure Python 3 (no numpy); gnuplot draws the
plot when it is installed.

What it computes, per run (rows of history.csv from the test's start):
  sigma_v   history.csv stress_Pa (load of the platen / area)
  e         history.csv void_ratio: (h A - V_s) / V_s with V_s the volume of
            the particles present (fines removed from the specimen excluded)
  e_fines   the same with the removed fines counted as solid:
            V_s + (volume of the fines removed so far, removed.csv)
  yield     sigma_y: the stress where e first falls 0.01 below the straight
            e - log10(sigma) line through the breakage onset with the slope
            of the curve before it (the knee; scripts/oedometer.sh's rule)
  NCL       the rows with sigma >= 2 sigma_y (--factor), up to the time the
            platen slows to rest (the last --tail-s seconds of the loading are left
            out) and only rows at a new stress maximum (the loading envelope:
            the stress drops after breakage events are skipped)
  slope     least squares of log10 e on log10 sigma over the NCL rows
            (-slope is compared with m / 6), also for the first and second
            half of the NCL stretch in log sigma (a curvature check) and for
            e_fines.
"""

import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys


def scene_values(path):
    """friction_from, weibull_modulus, density, area from a scene file."""
    text = open(path).read()

    def num(key):
        m = re.search(r"^\s*" + key + r"\s*=\s*([-0-9.eE+]+)", text, re.M)
        if not m:
            raise SystemExit(f"ncl.py: {path} has no '{key}'")
        return float(m.group(1))

    return {"friction_from": num("friction_from"), "m": num("weibull_modulus"),
            "density": num("density"), "area": num("area")}


def load_end_time(path):
    """The time of the platen's lowest key frame (the end of the loading), or None."""
    frames = re.findall(r"^\s*time\s*=\s*([-0-9.eE+]+)\s*\n\s*position\s*=\s*\[[^,]+,\s*([-0-9.eE+]+)",
                        open(path).read(), re.M)
    if not frames:
        return None
    lowest = min(frames, key=lambda f: (float(f[1]), float(f[0])))
    return float(lowest[0])


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fit(xs, ys):
    """Least squares y = a + s x: (s, a, r2)."""
    n = len(xs)
    if n < 3:
        return float("nan"), float("nan"), float("nan")
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys))
    syy = sum((y - my) ** 2 for y in ys)
    s = sxy / sxx
    a = my - s * mx
    r2 = sxy * sxy / (sxx * syy) if syy > 0 else 1.0
    return s, a, r2


def yield_stress(rows):
    """The knee: rows are dicts with s (Pa), e, b (breakages), from the test's start."""
    onset = next((k for k, r in enumerate(rows) if r["b"] > rows[0]["b"]), None)
    if onset is None:
        return None, None
    so = rows[onset]["s"]
    a = next((k for k in range(onset) if rows[k]["s"] > 0.05 * so), None)
    slope = 0.0
    if a is not None and a < onset and rows[a]["s"] > 0 and so > rows[a]["s"]:
        slope = (rows[onset]["e"] - rows[a]["e"]) / math.log10(so / rows[a]["s"])
    for r in rows[onset:]:
        if r["s"] <= 0:
            continue
        line = rows[onset]["e"] + slope * math.log10(r["s"] / so)
        if r["e"] < line - 0.01:
            return so, r["s"]
    return so, None


def ncl_rows(rows, sy, factor, t_end):
    """Rows of the loading envelope with sigma >= factor sigma_y and t <= t_end."""
    out, smax = [], 0.0
    for r in rows:
        if r["t"] > t_end:
            break
        if r["s"] > smax:
            smax = r["s"]
            if r["s"] >= factor * sy and r["e"] > 0:
                out.append(r)
    return out


def slopes(sel, key):
    xs = [math.log10(r["s"]) for r in sel]
    ys = [math.log10(r[key]) for r in sel]
    s, a, r2 = fit(xs, ys)
    res = {"slope": -s, "intercept": a, "r2": r2, "n": len(sel)}
    if len(sel) >= 6:
        mid = 0.5 * (xs[0] + xs[-1])
        lo = [(x, y) for x, y in zip(xs, ys) if x <= mid]
        hi = [(x, y) for x, y in zip(xs, ys) if x > mid]
        res["slope_first_half"] = -fit([p[0] for p in lo], [p[1] for p in lo])[0]
        res["slope_second_half"] = -fit([p[0] for p in hi], [p[1] for p in hi])[0]
    return res


def analyse(run, scene, factor, tail_s):
    sc = scene_values(scene)
    hist = read_csv(os.path.join(run, "history.csv"))
    removed = []
    rpath = os.path.join(run, "removed.csv")
    if os.path.exists(rpath):
        removed = [(float(r["time_s"]), float(r["volume"]), float(r["mass_kg"]))
                   for r in read_csv(rpath) if r["reason"] == "fines"]
    removed.sort()
    rows, k, vf = [], 0, 0.0
    for h in hist:
        t = float(h["time_s"])
        while k < len(removed) and removed[k][0] <= t + 1e-15:
            vf += removed[k][1]
            k += 1
        if t + 1e-12 < sc["friction_from"]:
            continue
        height, s, e = float(h["height_m"]), float(h["stress_Pa"]), float(h["void_ratio"])
        total = height * sc["area"]
        vs = total / (1.0 + e)
        ke, ue = float(h.get("kinetic_J") or 0), float(h.get("elastic_J") or 0)
        dh = 2.0 * ue / (s * sc["area"]) if s > 0 else 0.0
        rows.append({"t": t, "h": height, "s": s, "e": e, "e_fines": (total - vs - vf) / (vs + vf),
                     "e_plastic": ((height + dh) * sc["area"] - vs) / vs, "dh_el": dh,
                     "b": int(float(h["breakages"])), "p": int(float(h["particles"])),
                     "ke_ratio": ke / ue if ue > 0 else 0.0, "vf": vf, "vs": vs})
    if not rows:
        raise SystemExit(f"ncl.py: {run}: no history rows after friction_from {sc['friction_from']}")
    h0 = rows[0]["h"]
    onset, sy = yield_stress(rows)
    # The end of the scene's platen path (duration) when the run reached it; a
    # cut-off run ends earlier and keeps every row.
    summary = {}
    spath = os.path.join(run, "summary.json")
    if os.path.exists(spath):
        summary = json.load(open(spath))
    t_load_end = load_end_time(scene)
    t_last = rows[-1]["t"]
    t_end = t_load_end - tail_s if t_load_end is not None and t_last > t_load_end - tail_s else t_last
    loading = [r for r in rows if t_load_end is None or r["t"] <= t_load_end + 1e-12]
    last = loading[-1]
    res = {"run": run, "scene": scene, "m": sc["m"], "theory": sc["m"] / 6.0,
           "start_time_s": rows[0]["t"], "start_height_m": h0, "e0": rows[0]["e"], "s0_MPa": rows[0]["s"] / 1e6,
           "onset_MPa": onset / 1e6 if onset else None, "yield_MPa": sy / 1e6 if sy else None,
           "end_time_s": last["t"], "end_strain": (h0 - last["h"]) / h0, "end_MPa": last["s"] / 1e6,
           "max_MPa": max(r["s"] for r in loading) / 1e6,
           "end_e": last["e"], "end_e_fines": last["e_fines"], "end_e_plastic_estimate": last["e_plastic"],
           "end_dh_el_estimate_mm": 1e3 * last["dh_el"], "end_height_mm": 1e3 * last["h"],
           "breakages": last["b"], "particles": last["p"],
           "fines_percent_of_solids": 100.0 * last["vf"] / (last["vs"] + last["vf"]),
           "max_ke_ratio_above_0.5MPa": max((r["ke_ratio"] for r in rows if r["s"] > 0.5e6), default=0.0),
           "steps": summary.get("steps"), "wall_s": summary.get("wall_time"), "factor": factor,
           "run_end_time_s": t_last}
    # Unloading (rows after the loading's end): the height where the platen's
    # stress first falls under 1 % of the stress at the end of the loading.
    after = [r for r in rows if t_load_end is not None and r["t"] > t_load_end + 1e-12]
    zero = next((r for r in after if r["s"] < 0.01 * last["s"]), None)
    if zero:
        res["unloaded_height_mm"] = 1e3 * zero["h"]
        res["rebound_mm"] = 1e3 * (zero["h"] - last["h"])
        res["unloaded_e"] = zero["e"]
    elif after:
        res["unloading_reached_mm"] = 1e3 * after[-1]["h"]
        res["unloading_stress_MPa"] = after[-1]["s"] / 1e6
    sel = ncl_rows(rows, sy, factor, t_end) if sy else []
    if len(sel) >= 3:
        res["ncl_from_MPa"] = sel[0]["s"] / 1e6 if sel else None
        res["ncl_to_MPa"] = sel[-1]["s"] / 1e6 if sel else None
        res["ncl_decades"] = math.log10(sel[-1]["s"] / sel[0]["s"]) if len(sel) > 1 else 0.0
        res["fit"] = slopes(sel, "e")
        res["fit_fines"] = slopes(sel, "e_fines")
        res["fit_plastic"] = slopes(sel, "e_plastic")
        res["sensitivity"] = {}
        for f in (1.5, 3.0):
            s2 = ncl_rows(rows, sy, f, t_end)
            res["sensitivity"][str(f)] = slopes(s2, "e")["slope"] if len(s2) >= 3 else None
        res["diff_percent"] = 100.0 * (res["fit"]["slope"] - res["theory"]) / res["theory"]
    return res, rows


def write_outputs(results, curves, outdir, plot):
    os.makedirs(outdir, exist_ok=True)
    for res, rows in zip(results, curves):
        tag = "m%g" % res["m"]
        with open(os.path.join(outdir, f"curve_{tag}.dat"), "w") as f:
            f.write("# time_s stress_Pa void_ratio void_ratio_with_fines breakages particles "
                    "void_ratio_plastic_estimate\n")
            for r in rows:
                if r["s"] > 0 and (res["run_end_time_s"] <= res["end_time_s"] or r["t"] <= res["end_time_s"]):
                    f.write(f"{r['t']:.9g} {r['s']:.6g} {r['e']:.6g} {r['e_fines']:.6g} {r['b']} {r['p']} "
                            f"{r['e_plastic']:.6g}\n")
        with open(os.path.join(outdir, f"unloading_{tag}.dat"), "w") as f:
            f.write("# time_s stress_Pa void_ratio height_m (after the end of the loading)\n")
            for r in rows:
                if r["t"] > res["end_time_s"] and r["s"] > 0:
                    f.write(f"{r['t']:.9g} {r['s']:.6g} {r['e']:.6g} {r['h']:.6g}\n")
    with open(os.path.join(outdir, "ncl.json"), "w") as f:
        json.dump(results, f, indent=2)
    with open(os.path.join(outdir, "ncl.csv"), "w") as f:
        f.write("m,theory_m_over_6,slope,diff_percent,slope_with_fines,slope_first_half,slope_second_half,"
                "slope_from_1.5_sigma_y,slope_from_3_sigma_y,slope_plastic_estimate,r2,points,yield_MPa,ncl_from_MPa,ncl_to_MPa,ncl_decades,"
                "end_strain,end_e,max_MPa,breakages,particles,fines_percent_of_solids,max_ke_ratio\n")
        for r in results:
            fi = r.get("fit") or {}
            g = lambda v, p=4: ("nan" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{p}g}")
            f.write(",".join([g(r["m"]), g(r["theory"]), g(fi.get("slope")), g(r.get("diff_percent"), 3),
                              g((r.get("fit_fines") or {}).get("slope")), g(fi.get("slope_first_half")),
                              g(fi.get("slope_second_half")), g(r.get("sensitivity", {}).get("1.5")),
                              g(r.get("sensitivity", {}).get("3.0")), g((r.get("fit_plastic") or {}).get("slope")),
                              g(fi.get("r2")), str(fi.get("n", 0)),
                              g(r["yield_MPa"]), g(r.get("ncl_from_MPa")), g(r.get("ncl_to_MPa")),
                              g(r.get("ncl_decades"), 3), g(r["end_strain"]), g(r["end_e"]), g(r["max_MPa"]),
                              str(r["breakages"]), str(r["particles"]), g(r["fines_percent_of_solids"], 3),
                              g(r["max_ke_ratio_above_0.5MPa"], 3)]) + "\n")
    if not plot or not shutil.which("gnuplot"):
        return
    styles = ["lc rgb '#1f77b4'", "lc rgb '#d62728'", "lc rgb '#2ca02c'", "lc rgb '#9467bd'"]

    def panel(col, fitkey, what):
        lines = []
        for i, r in enumerate(results):
            tag = "m%g" % r["m"]
            st = styles[i % len(styles)]
            dat = os.path.join(outdir, f"curve_{tag}.dat")
            lines.append(f"'{dat}' using ($2/1e6):{col} with lines lw 2 {st} title 'lsdem, m = {r['m']:g}'")
            unl = os.path.join(outdir, f"unloading_{tag}.dat")
            if col == 3 and os.path.exists(unl) and os.path.getsize(unl) > 80:
                lines.append(f"'{unl}' using ($2/1e6):3 with lines lw 1 {st} title 'unloading, m = {r['m']:g}'")
            fi = r.get(fitkey)
            if fi and r.get("ncl_from_MPa"):
                a, sl = fi["intercept"], fi["slope"]
                lo, hi = r["ncl_from_MPa"] * 1e6, r["ncl_to_MPa"] * 1e6
                # the fit (dashed) and the theory's slope m/6 through the fit's middle (dotted)
                xm = 0.5 * (math.log10(lo) + math.log10(hi))
                ym = a - sl * xm
                lines.append(f"(x >= {lo/1e6:g} && x <= {hi/1e6:g}) ? 10**({a:.6g} - {sl:.6g}*log10(x*1e6)) : 1/0 "
                             f"with lines dt 2 lw 3 {st} title 'fit from 2 sigma_y: slope {sl:.3f}'")
                lo2, hi2 = lo / 2.0, hi * 2.0
                lines.append(f"(x >= {lo2/1e6:g} && x <= {hi2/1e6:g}) ? "
                             f"10**({ym:.6g} - {r['theory']:.6g}*(log10(x*1e6) - {xm:.6g})) : 1/0 "
                             f"with lines dt 3 lw 2 {st} title 'slope m/6 = {r['theory']:.3f}'")
        return f"set title '{what}'\nplot " + ", ".join(lines) + "\n"

    gp = f"""set terminal pngcairo size 1400,620 noenhanced
set output '{plot}'
set multiplot layout 1,2
set logscale xy
set grid xtics ytics mxtics mytics
set samples 400
set xrange [0.5:60]
set yrange [0.08:0.8]
set xlabel 'vertical stress sigma_v (MPa)'
set ylabel 'void ratio e'
set key bottom left
{panel(3, "fit", "e from the loaded height (contact overlap counts as compression)")}
set ylabel 'void ratio e + 2U/F (estimate)'
{panel(7, "fit_plastic", "e with the stored elastic compression 2U/F added back")}
unset multiplot
"""
    os.makedirs(os.path.dirname(os.path.abspath(plot)), exist_ok=True)
    subprocess.run(["gnuplot"], input=gp, text=True, check=True)


def table(results):
    print("| m | theory m/6 | NCL slope | difference | with fines as solid | first / second half | "
          "overlap removed (2U/F) | yield (MPa) | NCL stretch (MPa) | decades | points |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in results:
        fi = r.get("fit")
        if not fi:
            why = "no yield found" if not r["yield_MPa"] else "fewer than 3 points above %g sigma_y" % r["factor"]
            print(f"| {r['m']:g} | {r['theory']:.3f} | no NCL ({why}) | | | | | | | | |")
            continue
        print(f"| {r['m']:g} | {r['theory']:.3f} | {fi['slope']:.3f} | {r['diff_percent']:+.0f} % | "
              f"{r['fit_fines']['slope']:.3f} | {fi.get('slope_first_half', float('nan')):.3f} / "
              f"{fi.get('slope_second_half', float('nan')):.3f} | {r['fit_plastic']['slope']:.3f} | {r['yield_MPa']:.3g} | "
              f"{r['ncl_from_MPa']:.3g}-{r['ncl_to_MPa']:.3g} | {r['ncl_decades']:.2f} | {fi['n']} |")


def self_test():
    """A synthetic NCL: e = 0.6 flat-ish to sigma_y = 5 MPa, then e_y (sigma/sigma_y)^-(m/6); the fit must
    find m/6 within 1 % on the stretch from 2 sigma_y."""
    import tempfile
    ok = True
    for m in (3.0, 6.0):
        d = tempfile.mkdtemp(prefix="ncl-selftest-")
        scene = os.path.join(d, "scene.toml")
        with open(scene, "w") as f:
            f.write(f"friction_from = 0.01\ndensity = 2450.0\nweibull_modulus = {m}\narea = 1.0e-4\nduration = 0.03\n")
        sy, ey, a = 5e6, 0.55, 1e-4
        with open(os.path.join(d, "history.csv"), "w") as f:
            f.write("time_s,height_m,stress_Pa,strain,void_ratio,breakages,particles,kinetic_J,elastic_J\n")
            vs = 5e-3 * a / 1.6
            for i in range(2001):
                t = 0.01 + 0.02 * i / 2000
                s = 0.2e6 * 10 ** (3.0 * i / 2000)  # 0.2 MPa .. 200 MPa
                e = 0.6 - 0.05 * math.log10(s / 0.2e6) / math.log10(sy / 0.2e6) if s < sy else ey * (s / sy) ** (-m / 6)
                # a smooth knee: blend over 0.1 decade
                h = (1 + e) * vs / a
                b = 0 if s < 0.9 * sy else int(10 * math.log10(s / (0.9 * sy)) * 100)
                f.write(f"{t},{h},{s},0,{e},{b},100,1e-9,1e-6\n")
        res, _ = analyse(d, scene, 2.0, 0.0)
        err = abs(res["fit"]["slope"] - m / 6) / (m / 6)
        print(f"self-test m = {m:g}: yield {res['yield_MPa']:.3g} MPa, slope {res['fit']['slope']:.4f}, "
              f"m/6 {m/6:.4f}, error {100*err:.2f} %")
        ok = ok and err < 0.01 and 4e6 < res["yield_MPa"] * 1e6 < 7e6
        shutil.rmtree(d)
    print("self-test", "passed" if ok else "FAILED")
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="*", help="RUN_DIR=SCENE.toml")
    ap.add_argument("--out", default="ncl-out", help="folder for ncl.csv, ncl.json and the curves")
    ap.add_argument("--plot", default=None, help="PNG of log e against log sigma_v (gnuplot)")
    ap.add_argument("--factor", type=float, default=2.0, help="the NCL starts at factor x sigma_y (2)")
    ap.add_argument("--tail-s", type=float, default=0.0002,
                    help="s left out at the end of the loading, where the platen slows to rest (0.0002)")
    ap.add_argument("--self-test", action="store_true", help="check the fit on a synthetic power law")
    args = ap.parse_args()
    if args.self_test:
        return self_test()
    if not args.runs:
        ap.error("give RUN_DIR=SCENE.toml arguments (or --self-test)")
    results, curves = [], []
    for spec in args.runs:
        run, _, scene = spec.partition("=")
        res, rows = analyse(run, scene, args.factor, args.tail_s)
        results.append(res)
        curves.append(rows)
    write_outputs(results, curves, args.out, args.plot)
    table(results)
    for r in results:
        print(f"m = {r['m']:g}: e0 {r['e0']:.3f} at {r['s0_MPa']:.3g} MPa; onset {r['onset_MPa']} MPa; "
              f"end strain {r['end_strain']:.3f}, e {r['end_e']:.3f} ({r['end_e_fines']:.3f} with fines), "
              f"max {r['max_MPa']:.3g} MPa; {r['breakages']} breakages, {r['particles']} particles, "
              f"fines {r['fines_percent_of_solids']:.2f} % of the solids; max KE/elastic {r['max_ke_ratio_above_0.5MPa']:.3g}; "
              f"steps {r['steps']}, wall {r['wall_s']} s; end of loading: h {r['end_height_mm']:.4f} mm, "
              f"2U/F {r['end_dh_el_estimate_mm']:.4f} mm, e without it {r['end_e_plastic_estimate']:.3f}; "
              f"unloading: " + (f"stress gone at h {r['unloaded_height_mm']:.4f} mm (rebound {r['rebound_mm']:.4f} mm, "
                                f"e {r['unloaded_e']:.3f})" if "rebound_mm" in r else
                                f"reached {r.get('unloading_reached_mm', float('nan')):.4f} mm at "
                                f"{r.get('unloading_stress_MPa', float('nan')):.3g} MPa" if "unloading_reached_mm" in r
                                else "none"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
