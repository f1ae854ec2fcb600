#!/usr/bin/env pvpython
"""A finished (or running) lsdem run folder in ParaView with a ready view.

    pvpython paraview_view.py DIR [--screenshot FILE.png] [--time T]
                                  [--size WxH] [--color auto|id|generation]
                                  [--state FILE.pvsm]

`lsdem paraview DIR ...` runs this script (docs/paraview.md, "One command").
It opens the run's series (particles.pvd, surfaces.pvd, boundaries.pvd and
contacts.pvd, those that exist) and shows:

- surfaces coloured by particle `generation` once a grain has broken at the
  shown time, else by particle `id` (`--color` to choose), with a legend;
  3D surfaces are slightly transparent when force chains are drawn, so the
  chains inside touching grains show; 2D grains (polygons) are filled in a
  pale colour under a dark outline;
- particles as sphere glyphs at their centroids: with surfaces, small white
  markers (0.2 x `equivalent_diameter`) that the force chains join; without
  surfaces, spheres of the grain's volume (`equivalent_diameter`, or twice
  `radius` when that is all there is);
- force chains (contacts.pvd) as tubes whose radius and colour follow
  `force_magnitude`, with a legend;
- boundaries (planes and tools; one block per plane set and tool) in grey,
  semi-transparent in 3D, tools filled in 2D;
- the simulated time (AnnotateTimeFilter, in ms) and the particle count;
- the camera fitted to the scene: 3D from an oblique view, 2D from +z with a
  parallel projection.

With --screenshot it renders offscreen and writes a PNG (no window; under
Debian's ParaView an X server is still needed: run it under `xvfb-run -a`
when there is no display, as `lsdem paraview` does). With --state it writes a
ParaView state file (it too needs an X server to build the view) (open it with `paraview --state=FILE.pvsm`). With neither
it writes the state to a temporary file and starts the ParaView GUI on it.

Exit codes: 0 done, 1 failed, 2 bad input (not a run folder, bad option).
Checked with ParaView 5.11 (Debian 12's paraview / python3-paraview).
"""

import argparse
import builtins  # max, min, ... by name: ParaView's Python filters can shadow them in __main__
import json
import math
import os
import shutil
import sys
import tempfile

SERIES = ("particles", "surfaces", "boundaries", "contacts")

def fail(message, code=2):
    sys.stderr.write("paraview_view: %s\n" % message)
    sys.exit(code)


def parse_args(argv):
    p = argparse.ArgumentParser(prog="paraview_view.py",
                                description="Show an lsdem run folder in ParaView with a ready view.")
    p.add_argument("dir", help="the run's output folder")
    p.add_argument("--screenshot", metavar="FILE.png", help="render offscreen and save a PNG")
    p.add_argument("--time", type=float, metavar="T",
                   help="simulated time to show, s (the nearest frame; default the last)")
    p.add_argument("--size", default="1200x800", metavar="WxH", help="screenshot size in pixels (default 1200x800)")
    p.add_argument("--color", default="auto", choices=("auto", "id", "generation"),
                   help="surfaces coloured by: auto (generation once a grain has broken, else id), id, generation")
    p.add_argument("--state", metavar="FILE.pvsm", help="save a ParaView state file instead of opening the GUI")
    a = p.parse_args(argv)
    try:
        w, h = (int(v) for v in a.size.lower().split("x"))
        if not (64 <= w <= 8000 and 64 <= h <= 8000):
            raise ValueError
        a.size = (w, h)
    except ValueError:
        fail("--size: expected WxH with 64..8000 pixels each, got '%s'" % a.size)
    if a.time is not None and not math.isfinite(a.time):
        fail("--time: must be a finite number")
    if a.screenshot and a.state:
        fail("give either --screenshot or --state, not both")
    return a


def run_dimension(folder, bounds):
    """2 or 3: summary.json's `dimension`, else the run's scene.toml, else flat in z."""
    try:
        with open(os.path.join(folder, "summary.json")) as f:
            d = int(json.load(f)["dimension"])
            if d in (2, 3):
                return d
    except (OSError, ValueError, KeyError, TypeError):
        pass
    try:
        with open(os.path.join(folder, "scene.toml")) as f:
            for line in f:
                key, _, value = line.partition("=")
                if key.strip() == "dimension":
                    return int(value.split("#")[0].strip())
    except (OSError, ValueError):
        pass
    return 2 if bounds and abs(bounds[5] - bounds[4]) <= 1e-12 * max(1.0, abs(bounds[1] - bounds[0])) else 3


def main(argv):
    a = parse_args(argv)
    folder = os.path.abspath(a.dir)
    if not os.path.isdir(folder):
        fail("%s: not a folder" % a.dir)
    files = {s: os.path.join(folder, s + ".pvd") for s in SERIES if os.path.isfile(os.path.join(folder, s + ".pvd"))}
    if not files:
        fail("%s: not a run folder (none of particles.pvd, surfaces.pvd, boundaries.pvd, contacts.pvd)" % a.dir)
    gui = None
    if not a.screenshot and not a.state:
        gui = shutil.which("paraview") or ("/usr/bin/paraview" if os.access("/usr/bin/paraview", os.X_OK) else None)
        if not gui:
            fail("the ParaView GUI is not installed (apt-get install paraview); give --screenshot or --state")
        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            fail("no display for the ParaView GUI: give --screenshot FILE.png or --state FILE.pvsm")

    # Imported here so that --help and bad input answer at once.
    import paraview
    paraview.compatibility.major, paraview.compatibility.minor = 5, 11
    from paraview import servermanager as sm
    import paraview.simple as pv
    pv._DisableFirstRenderCameraReset()

    readers = {}
    for s, path in files.items():
        r = pv.PVDReader(registrationName=s + ".pvd", FileName=path)
        readers[s] = r
    times = []
    for r in readers.values():
        tv = r.TimestepValues
        try:
            times.extend(float(v) for v in tv)
        except TypeError:
            times.append(float(tv))
    times = sorted(set(float(t) for t in times))
    if not times:
        fail("%s: the series list no frames" % a.dir, 1)
    t = times[-1] if a.time is None else builtins.min(times, key=lambda v: builtins.abs(v - a.time))

    scene = pv.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    view = pv.GetActiveViewOrCreate("RenderView")
    view.ViewSize = list(a.size)
    scene.AnimationTime = t
    view.ViewTime = t
    for r in readers.values():
        r.UpdatePipeline(t)

    def data_info(src):
        return src.GetDataInformation()

    def array_range(src, name, assoc):
        arrays = src.CellData if assoc == "CELLS" else src.PointData
        if name not in arrays.keys():
            return None
        return arrays[name].GetRange(0)

    # Scene extent and dimension, from every series at the shown time.
    bounds = None
    for r in readers.values():
        info = data_info(r)
        if info.GetNumberOfPoints() == 0:
            continue
        b = info.GetBounds()
        bounds = list(b) if bounds is None else [builtins.min(bounds[i], b[i]) if i % 2 == 0 else builtins.max(bounds[i], b[i])
                                                 for i in range(6)]
    dim = run_dimension(folder, bounds)
    # What the camera frames: the grains (surfaces, else particles grown by
    # their radius) and the chains between them; boundaries only when there
    # is nothing else (walls and tools reach to the scene's domain, which can
    # be far larger than the grains).
    fit = None
    has_surfaces = "surfaces" in readers and data_info(readers["surfaces"]).GetNumberOfPoints() > 0
    for s in ("surfaces", "particles", "contacts"):
        if s not in readers or data_info(readers[s]).GetNumberOfPoints() == 0:
            continue
        if s == "particles" and has_surfaces:
            continue
        b = list(data_info(readers[s]).GetBounds())
        if s == "particles":
            rr = array_range(readers[s], "radius", "POINTS")
            grow = rr[1] if rr else 0.0
            b = [b[i] - grow if i % 2 == 0 else b[i] + grow for i in range(6)]
            if dim == 2:
                b[4] = b[5] = 0.0
        fit = b if fit is None else [builtins.min(fit[i], b[i]) if i % 2 == 0 else builtins.max(fit[i], b[i])
                                     for i in range(6)]
    if fit is None:
        fit = bounds
    extent = 1.0
    if bounds:
        extent = builtins.max(bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4], 1e-300)

    # A typical grain size: the median equivalent diameter at the shown time.
    grain = None
    if "particles" in readers:
        pdata = sm.Fetch(readers["particles"])
        arr = pdata.GetPointData().GetArray("equivalent_diameter") if pdata else None
        if arr is None and pdata:
            arr = pdata.GetPointData().GetArray("radius")
        if arr is not None and arr.GetNumberOfTuples() > 0:
            vals = sorted(arr.GetValue(i) for i in range(arr.GetNumberOfTuples()))
            grain = vals[len(vals) // 2] * (2.0 if arr.GetName() == "radius" else 1.0)
    if not grain or grain <= 0:
        grain = extent / 20.0

    view.Background = [1.0, 1.0, 1.0]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    view.OrientationAxesVisibility = 1 if dim == 3 else 0
    view.OrientationAxesLabelColor = [0.1, 0.1, 0.1]
    dark = [0.1, 0.1, 0.1]

    def legend(display, lut, title):
        bar = pv.GetScalarBar(lut, view)
        bar.Title = title
        bar.ComponentTitle = ""
        bar.TitleColor = dark
        bar.LabelColor = dark
        bar.TitleFontSize = 16
        bar.LabelFontSize = 14
        bar.ScalarBarLength = 0.33
        bar.Visibility = 1
        display.SetScalarBarVisibility(view, True)
        return bar

    def integer_labels(bar, lo, hi):
        """Whole-number labels only, at most about six of them, the ends included."""
        lo, hi = int(math.floor(lo)), int(math.ceil(hi))
        step = builtins.max(1, int(math.ceil((hi - lo) / 5.0)))
        ticks = list(range(lo, hi + 1, step))
        if ticks[-1] != hi:
            ticks.append(hi)
        bar.AutomaticLabelFormat = 0
        bar.LabelFormat = "%.0f"
        bar.RangeLabelFormat = "%.0f"
        bar.AddRangeLabels = 0
        bar.UseCustomLabels = 1
        bar.CustomLabels = [float(v) for v in ticks]

    has_contacts = "contacts" in readers
    # --- surfaces
    if "surfaces" in readers:
        r = readers["surfaces"]
        if dim == 2:
            # The outlines (each a polygon) as dark lines, over the grains filled:
            # the polygons cut into triangles (concave outlines included) and
            # moved a little below z = 0, so lines and tubes stay on top.
            outline = pv.Show(r, view)
            outline.Representation = "Wireframe"
            outline.ColorArrayName = ["POINTS", ""]
            outline.AmbientColor = outline.DiffuseColor = [0.15, 0.15, 0.15]
            outline.LineWidth = 1.5
            triangles = pv.Triangulate(registrationName="grain triangles", Input=r)
            fill = pv.Transform(registrationName="filled grains", Input=triangles)
            fill.Transform = "Transform"
            fill.Transform.Translate = [0.0, 0.0, -0.002 * extent]
            d = pv.Show(fill, view)
        else:
            d = pv.Show(r, view)
        d.Representation = "Surface"
        gen_range = array_range(r, "generation", "CELLS")
        field = a.color
        if field == "auto":
            field = "generation" if gen_range and gen_range[1] > 0 else "id"
        if array_range(r, field, "CELLS") is None:
            field = "id" if array_range(r, "id", "CELLS") is not None else None
        if field:
            pv.ColorBy(d, ("CELLS", field))
            lut = pv.GetColorTransferFunction(field)
            rng = array_range(r, field, "CELLS") or (0, 1)
            if field == "generation":
                # One colour band per generation, each centred on its number.
                lut.ApplyPreset("Spectral_lowBlue", True)
                hi = builtins.max(1, int(rng[1]))
                lut.AutomaticRescaleRangeMode = "Never"
                lut.RescaleTransferFunction(-0.5, hi + 0.5)
                lut.NumberOfTableValues = hi + 1
                lut.Discretize = 1
                bar = legend(d, lut, "generation")
                integer_labels(bar, 0, hi)
            else:
                lut.ApplyPreset("Turbo", True)
                lo, hi = float(rng[0]), float(builtins.max(rng[1], rng[0] + 1))
                lut.AutomaticRescaleRangeMode = "Never"
                lut.RescaleTransferFunction(lo, hi)
                bar = legend(d, lut, "particle id")
                integer_labels(bar, lo, hi)
            bar.WindowLocation = "Any Location"
            bar.Orientation = "Vertical"
            bar.Position = [0.89, 0.52]
        if dim == 3:
            d.Specular = 0.3
            d.Opacity = 0.7 if has_contacts and data_info(readers["contacts"]).GetNumberOfCells() > 0 else 1.0
        else:
            # Flat, unlit and pastel on white: the outlines and force chains stay readable.
            d.Ambient, d.Diffuse = 1.0, 0.0
            d.Opacity = 0.55

    # --- particles as sphere glyphs
    if "particles" in readers:
        r = readers["particles"]
        if data_info(r).GetNumberOfPoints() > 0:
            scale = "equivalent_diameter" if array_range(r, "equivalent_diameter", "POINTS") else (
                "radius" if array_range(r, "radius", "POINTS") else None)
            g = pv.Glyph(registrationName="particle glyphs", Input=r, GlyphType="Sphere")
            g.OrientationArray = ["POINTS", "No orientation array"]
            g.GlyphMode = "All Points"
            g.GlyphType.ThetaResolution = 24
            g.GlyphType.PhiResolution = 16
            markers = "surfaces" in readers
            if scale:
                g.ScaleArray = ["POINTS", scale]
                # The sphere source's radius is 0.5: factor 1 x diameter = the grain's sphere.
                base = 1.0 if scale == "equivalent_diameter" else 2.0
                g.ScaleFactor = base * (0.2 if markers else 1.0)
            else:
                g.ScaleArray = ["POINTS", "No scale array"]
                g.ScaleFactor = grain * (0.2 if markers else 1.0)
            gd = pv.Show(g, view)
            if markers:
                gd.ColorArrayName = ["POINTS", ""]
                gd.AmbientColor = gd.DiffuseColor = [0.95, 0.95, 0.95]
            else:
                pv.ColorBy(gd, ("POINTS", "generation" if array_range(r, "generation", "POINTS") else "id"))
                gd.LookupTable.ApplyPreset("Viridis (matplotlib)", True)
                legend(gd, gd.LookupTable, "generation")

    # --- force chains as tubes by force_magnitude
    if has_contacts:
        r = readers["contacts"]
        rng = array_range(r, "force_magnitude", "POINTS")
        fmax = rng[1] if rng else 0.0
        tube = pv.Tube(registrationName="force chains", Input=r)
        tube.Scalars = ["POINTS", "force_magnitude"]
        tube.VaryRadius = "By Scalar"
        tube.Radius = 0.012 * grain
        tube.RadiusFactor = 4.0  # the strongest chain 4x the weakest's radius
        tube.NumberofSides = 16
        tube.Capping = 1
        td = pv.Show(tube, view)
        pv.ColorBy(td, ("POINTS", "force_magnitude"))
        flut = pv.GetColorTransferFunction("force_magnitude")
        # Grey for the weakest to black for the strongest: chains read over any grain colour.
        top = fmax if fmax > 0 else 1.0
        flut.AutomaticRescaleRangeMode = "Never"
        flut.RGBPoints = [0.0, 0.72, 0.72, 0.72, top, 0.0, 0.0, 0.0]
        flut.ColorSpace = "RGB"
        bar = legend(td, flut, "contact force (N)")
        bar.WindowLocation = "Any Location"
        bar.Orientation = "Vertical"
        bar.Position = [0.89, 0.08]
        bar.AutomaticLabelFormat = 0
        bar.LabelFormat = "%.3g"
        bar.RangeLabelFormat = "%.3g"
        if fmax <= 0:
            pv.Hide(tube, view)

    # --- boundaries
    if "boundaries" in readers:
        r = readers["boundaries"]
        d = pv.Show(r, view)
        d.ColorArrayName = ["POINTS", ""]
        d.AmbientColor = d.DiffuseColor = [0.45, 0.47, 0.5]
        if dim == 2:
            d.LineWidth = 2.0
        else:
            # Walls seen from inside only: the planes' polygons face into the
            # domain, so those between the camera and the grains are culled.
            d.Opacity = 0.15
            d.BackfaceRepresentation = "Cull Backface"
            d.Representation = "Surface With Edges"
            d.EdgeColor = [0.3, 0.3, 0.35]

    # --- time and particle count
    src = readers.get("particles") or next(iter(readers.values()))
    ann = pv.PythonAnnotation(registrationName="time", Input=src)
    ann.ArrayAssociation = "Point Data"
    ann.Expression = ("'t = %.4g ms   %d particles' % (t_value * 1e3, input.GetNumberOfPoints())"
                      if "particles" in readers else "'t = %.4g ms' % (t_value * 1e3)")
    ad = pv.Show(ann, view)
    ad.WindowLocation = "Upper Left Corner"
    ad.FontSize = 20
    ad.Color = dark
    title = pv.Text(registrationName="title")
    title.Text = "lsdem %dD: %s" % (dim, os.path.basename(folder.rstrip("/")))
    tdisp = pv.Show(title, view)
    tdisp.WindowLocation = "Upper Right Corner"
    tdisp.FontSize = 16
    tdisp.Color = [0.3, 0.3, 0.3]

    # --- camera: the box `fit` framed, with room on the right for the legends.
    w, h = a.size
    aspect = 0.8 * w / h
    box = fit or [-0.5, 0.5, -0.5, 0.5, -0.5, 0.5]
    centre = [(box[0] + box[1]) / 2, (box[2] + box[3]) / 2, (box[4] + box[5]) / 2]
    if dim == 2:
        toward, up = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)  # from +z, y up
    else:
        az, el = math.radians(35.0), math.radians(20.0)  # front-right, a little above, z up
        toward, up = (math.cos(el) * math.sin(az), -math.cos(el) * math.cos(az), math.sin(el)), (0.0, 0.0, 1.0)
    # The camera's right and true up directions; the box's half sizes along them.
    right = (up[1] * toward[2] - up[2] * toward[1], up[2] * toward[0] - up[0] * toward[2],
             up[0] * toward[1] - up[1] * toward[0])
    norm = math.sqrt(builtins.sum(c * c for c in right))
    right = tuple(c / norm for c in right)
    true_up = (toward[1] * right[2] - toward[2] * right[1], toward[2] * right[0] - toward[0] * right[2],
               toward[0] * right[1] - toward[1] * right[0])
    corners = [(x, y, z) for x in box[0:2] for y in box[2:4] for z in box[4:6]]

    def half(axis):
        return builtins.max(builtins.abs(builtins.sum((p[k] - centre[k]) * axis[k] for k in range(3))) for p in corners)

    half_r, half_u, half_d = half(right), half(true_up), half(toward)
    margin = 1.08
    view.CameraFocalPoint = centre
    view.CameraViewUp = list(true_up)
    if dim == 2:
        view.InteractionMode = "2D"
        view.CameraParallelProjection = 1
        view.CameraPosition = [centre[0], centre[1], centre[2] + 10 * extent]
        view.CameraParallelScale = margin * builtins.max(half_u, half_r / aspect, 1e-300)
    else:
        view.InteractionMode = "3D"
        view.CameraParallelProjection = 0
        angle = 30.0
        view.CameraViewAngle = angle
        tan_half = math.tan(math.radians(angle / 2))
        distance = margin * builtins.max(half_u, half_r / aspect, 1e-300) / tan_half + half_d
        view.CameraPosition = [centre[k] + distance * toward[k] for k in range(3)]

    if a.screenshot:
        out = os.path.abspath(a.screenshot)
        os.makedirs(os.path.dirname(out), exist_ok=True)
        pv.SaveScreenshot(out, view, ImageResolution=list(a.size), TransparentBackground=0)
        print("wrote %s (t = %.6g s)" % (out, t))
        # Leave without tearing the render window down: Debian's ParaView 5.11
        # under Xvfb can end in a GLXBadContext X error (exit code 1) there.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
    if a.state:
        out = os.path.abspath(a.state)
        pv.SaveState(out)
        print("wrote %s: open it with paraview --state=%s" % (out, out))
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
    fd, state = tempfile.mkstemp(prefix="lsdem-", suffix=".pvsm")
    os.close(fd)
    pv.SaveState(state)
    sys.stdout.flush()
    os.execv(gui, [gui, "--state=" + state])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
