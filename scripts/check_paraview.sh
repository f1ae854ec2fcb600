#!/usr/bin/env bash
# Checks that ParaView's own readers load every VTK file lsdem writes, and
# that `lsdem paraview` makes a screenshot (docs/paraview.md). Needs pvpython
# (Debian: apt-get install paraview python3-paraview xvfb); without it, says
# so in one line and exits 0.
#
# Runs short 3D and 2D three-grains scenes in every frame encoding
# ([output] vtk_format: compressed, the default, appended, binary, ascii;
# scene copies with the key added sit beside the scene while they run and are
# removed afterwards), then with pvpython opens every .pvd (PVDReader: one
# time step per listed frame) and every .vtp (XMLPolyDataReader: the points
# and cells the file's header declares, > 0 where lsdem always writes some,
# and the arrays docs/paraview.md lists), checks that the particles' points
# are the same in every encoding, and makes one offscreen screenshot of each
# dimension with `lsdem paraview DIR --screenshot`.
#
#   bash scripts/check_paraview.sh            # build/apps/lsdem
#   LSDEM=/path/to/lsdem bash scripts/check_paraview.sh
set -euo pipefail
cd "$(dirname "$0")/.."
pvpython=$(command -v pvpython || true)
[[ -f $pvpython && -x $pvpython ]] || pvpython=/usr/bin/pvpython
if ! [[ -f $pvpython && -x $pvpython ]]; then
  echo "check_paraview: pvpython is not installed (apt-get install paraview python3-paraview); skipped"
  exit 0
fi
lsdem=${LSDEM:-${LSDEM_BUILD_DIR:-build}/apps/lsdem}
[[ -x $lsdem ]] || { echo "check_paraview: $lsdem not built (cmake --build build --target lsdem)" >&2; exit 1; }
start=$SECONDS

scenes=apps/scenes/three_grains
work=$(mktemp -d)
copies=()
cleanup() {
  rm -rf "$work" "$work.pieces"
  for c in "${copies[@]}"; do rm -f "$c"; done
}
trap cleanup EXIT

# run NAME DIM FORMAT STEPS [SCENE]: the scene (default three grains of that
# dimension), with vtk_format = FORMAT under [output], into $work/NAME.
run() {
  local name=$1 dim=$2 format=$3 steps=$4
  local scene=${5:-$scenes/three_grains_${dim}.toml}
  if [[ $format != compressed ]]; then
    local copy=$scenes/.check_paraview_$$_${name}.toml
    copies+=("$copy")
    awk -v f="$format" '{ print } /^\[output\][[:space:]]*$/ { print "vtk_format = \"" f "\"" }' "$scene" >"$copy"
    grep -q "^vtk_format = \"$format\"" "$copy" || { echo "check_paraview: no [output] in $scene" >&2; exit 1; }
    scene=$copy
  fi
  local args=(run "$scene" --out "$work/$name" --threads 1 -q)
  [[ $steps == all ]] || args+=(--steps "$steps")
  "$lsdem" "${args[@]}"
}
run 3d-compressed 3d compressed 3000
run 3d-ascii 3d ascii 3000
run 2d-compressed 2d compressed all
run 2d-binary 2d binary 6000
run 2d-appended 2d appended 6000
run 2d-ascii 2d ascii 6000
# Tools: the jaw crusher's moving jaw (a file per frame) beside its fixed jaw
# (written once): boundaries.pvd frames of several parts.
run 2d-tools 2d compressed 400 apps/scenes/jaw_crusher/jaw_crusher_css100.toml
for c in "${copies[@]}"; do rm -f "$c"; done
copies=()
# A distributed run's frames in per-rank pieces ([output] frame_pieces =
# "ranks", docs/parallel.md): the 2D scene of the 2d-binary run on 2 ranks,
# outside $work (its files are .pvtp indices and their pieces).
pieces=""
if command -v mpirun >/dev/null && [[ $(ldd "$lsdem") == *libmpi* ]]; then
  pieces=$work.pieces
  mkdir -p "$pieces"
  awk '{ print } /^\[output\][[:space:]]*$/ { print "vtk_format = \"binary\""; print "frame_pieces = \"ranks\"" }' \
    "$scenes/three_grains_2d.toml" >"$pieces/scene.toml"
  mpirun --allow-run-as-root --oversubscribe -np 2 -x OMP_NUM_THREADS=1 \
    "$lsdem" run "$pieces/scene.toml" --out "$pieces/2d-pieces" --threads 1 -q --steps 6000
fi
echo "check_paraview: runs done ($((SECONDS - start)) s)"

status=0
# pvpython refuses an empty argument (it cannot decode it), so the pieces
# folder is passed only when there is one.
read_args=("$work")
[[ -n $pieces ]] && read_args+=("$pieces")
"$pvpython" - "${read_args[@]}" >"$work/read.log" 2>&1 <<'PY' || status=$?
import glob, os, re, sys
from paraview import servermanager as sm
import paraview.simple as pv

work = sys.argv[1]
# The arrays docs/paraview.md lists, per series: (point data, cell data).
ARRAYS = {
    "particles": (["id", "parent_id", "generation", "radius", "equivalent_diameter", "mass", "velocity",
                   "angular_velocity", "orientation", "axis_x", "axis_y", "axis_z", "stress", "strength",
                   "criterion_ratio", "mean_stress", "von_mises_stress", "principal_stress"], []),
    "surfaces": ([], ["id", "generation"]),
    "boundaries": ([], ["kind", "index"]),
    "contacts": (["id", "force_magnitude", "normal_force"],
                 ["force", "force_magnitude", "normal_force", "tangential_force", "node_contacts", "id_a", "id_b"]),
}
COMPONENTS = {"velocity": 3, "angular_velocity": 3, "orientation": 4, "axis_x": 3, "axis_y": 3, "axis_z": 3,
              "force": 3, "principal_stress": 3}
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def header_counts(path):
    with open(path, "rb") as f:
        head = f.read(4096).decode("latin-1")
    m = re.search(r'<Piece NumberOfPoints="(\d+)" NumberOfVerts="(\d+)" NumberOfLines="(\d+)" '
                  r'NumberOfStrips="(\d+)" NumberOfPolys="(\d+)"', head)
    return tuple(int(v) for v in m.groups()) if m else None


totals = {}
last_points = {}
for run in sorted(d for d in os.listdir(work) if os.path.isdir(os.path.join(work, d))):
    folder = os.path.join(work, run)
    nfiles = 0
    contacts_cells = 0
    for series, (pnames, cnames) in ARRAYS.items():
        pvd = os.path.join(folder, series + ".pvd")
        if not os.path.isfile(pvd):
            check(run == "2d-tools" and series == "contacts", "%s: %s.pvd missing" % (run, series))
            continue  # the jaw crusher scene writes no contacts
        # Entries (part, file); a part-0 entry starts a frame (boundaries: the
        # planes, then one part per tool; a file can be named by many frames).
        entries = [(int(p), f) for p, f in re.findall(r'part="(\d+)" file="([^"]+)"', open(pvd).read())]
        listed = [f for _, f in entries]
        nframes = sum(1 for p, _ in entries if p == 0)
        last_frame = entries[max(k for k, (p, _) in enumerate(entries) if p == 0):] if nframes else []
        r = pv.PVDReader(FileName=pvd)
        steps = r.TimestepValues
        steps = list(steps) if hasattr(steps, "__len__") else [steps]
        check(len(steps) == nframes > 0, "%s: %s.pvd: %d time steps for %d frames" % (run, series, len(steps), nframes))
        r.UpdatePipeline(steps[-1])
        info = r.GetDataInformation()
        last = [header_counts(os.path.join(folder, f)) for _, f in last_frame]
        check(None not in last and info.GetNumberOfPoints() == sum(c[0] for c in last),
              "%s: %s.pvd at the last time: %d points, the frame's parts say %s" % (run, series, info.GetNumberOfPoints(), last))
        frames = sorted(glob.glob(os.path.join(folder, "frames", series + "_*.vtp")))
        check(len(frames) == len(set(listed)), "%s: %d %s frames on disk, %d listed" % (run, len(frames), series, len(set(listed))))
        for path in frames:
            nfiles += 1
            name = "%s/%s" % (run, os.path.relpath(path, folder))
            counts = header_counts(path)
            if not check(counts is not None, name + ": no <Piece> header"):
                continue
            npts, nverts, nlines, nstrips, npolys = counts
            reader = pv.XMLPolyDataReader(FileName=[path])
            reader.UpdatePipeline()
            data = sm.Fetch(reader)
            check(data.GetNumberOfPoints() == npts, "%s: %d points read, %d declared" % (name, data.GetNumberOfPoints(), npts))
            check(data.GetNumberOfCells() == nverts + nlines + nstrips + npolys,
                  "%s: %d cells read, %d declared" % (name, data.GetNumberOfCells(), nverts + nlines + nstrips + npolys))
            check(data.GetNumberOfVerts() == nverts and data.GetNumberOfLines() == nlines and
                  data.GetNumberOfPolys() == npolys, "%s: cell kinds differ from the header" % name)
            if series == "boundaries" and path.endswith("_planes.vtp") and run.startswith("2d-tools"):
                pass  # the jaw crusher has no planes
            elif series != "contacts":
                check(npts > 0 and data.GetNumberOfCells() > 0, "%s: empty" % name)
            else:
                contacts_cells += data.GetNumberOfCells()
            # 2D surfaces and tools: polygons (ParaView fills them); 2D planes: segments.
            if series == "surfaces" or (series == "boundaries" and "_tool" in path):
                check(nlines == 0 and npolys == data.GetNumberOfCells(), "%s: %d lines, %d polygons" % (name, nlines, npolys))
            for assoc, names, fd in (("point", pnames, data.GetPointData()), ("cell", cnames, data.GetCellData())):
                if npts == 0:
                    continue
                for a in names:
                    arr = fd.GetArray(a)
                    if not check(arr is not None, "%s: %s array %s missing" % (name, assoc, a)):
                        continue
                    n = npts if assoc == "point" else data.GetNumberOfCells()
                    check(arr.GetNumberOfTuples() == n and arr.GetNumberOfComponents() == COMPONENTS.get(a, 1),
                          "%s: %s has %d x %d values, expected %d x %d" % (name, a, arr.GetNumberOfTuples(),
                                                                         arr.GetNumberOfComponents(), n, COMPONENTS.get(a, 1)))
            if series == "particles" and path == frames[-1]:
                pts = data.GetPoints()
                last_points[run] = [pts.GetPoint(i) for i in range(npts)]
            pv.Delete(reader)
        pv.Delete(r)
    if run.startswith("2d-compressed"):
        check(contacts_cells > 0, run + ": no contact in any contacts frame")
    if run == "2d-tools":
        # The fixed jaw written once, the moving jaw in every frame.
        tools = re.findall(r'file="(frames/boundaries_\d+_tool(\d+)\.vtp)"', open(os.path.join(folder, "boundaries.pvd")).read())
        per_tool = {}
        for f, k in tools:
            per_tool.setdefault(k, set()).add(f)
        check(sorted(len(v) for v in per_tool.values())[0] == 1 and sorted(len(v) for v in per_tool.values())[-1] > 1,
              "%s: tool files per tool %s: expected one tool written once and one per frame" % (run, {k: len(v) for k, v in per_tool.items()}))
    totals[run] = nfiles
    print("check_paraview: %s: %d .vtp files and their .pvd series read by ParaView" % (run, nfiles))

# The same run in every encoding: the same particles (positions are Float64 in all).
for dim in ("2d", "3d"):
    runs = [r for r in last_points if r.startswith(dim) and r not in (dim + "-compressed", dim + "-tools")]
    ref = dim + "-compressed" if dim == "3d" else None
    if ref is None:  # the 2D compressed run went to the end; the others stopped at 6000 steps
        runs = sorted(runs)
        ref = runs.pop(0) if runs else None
    for r in runs:
        check(last_points[r] == last_points[ref], "%s and %s: particles' last frames differ" % (r, ref))

# Frames in per-rank pieces: each .pvd lists .pvtp indices of 2 pieces, and
# ParaView reads them as the frames of the same run written whole (2d-binary).
if len(sys.argv) > 2:
    folder = os.path.join(sys.argv[2], "2d-pieces")
    whole = os.path.join(work, "2d-binary")
    for series in ("particles", "surfaces", "contacts"):
        pvd = os.path.join(folder, series + ".pvd")
        listed = re.findall(r'file="([^"]+)"', open(pvd).read())
        check(listed and all(f.endswith(".pvtp") for f in listed), "2d-pieces: %s.pvd lists %s" % (series, listed[:2]))
        for f in listed[-1:]:
            check(open(os.path.join(folder, f)).read().count("<Piece ") == 2, "2d-pieces: %s names not 2 pieces" % f)
        a, b = pv.PVDReader(FileName=pvd), pv.PVDReader(FileName=os.path.join(whole, series + ".pvd"))
        ta, tb = list(a.TimestepValues), list(b.TimestepValues)
        check(len(ta) == len(tb), "2d-pieces: %s: %d time steps, the whole frames %d" % (series, len(ta), len(tb)))
        a.UpdatePipeline(ta[-1])
        b.UpdatePipeline(tb[-1])
        da, db = sm.Fetch(a), sm.Fetch(b)
        check(da.GetNumberOfPoints() == db.GetNumberOfPoints() and da.GetNumberOfCells() == db.GetNumberOfCells(),
              "2d-pieces: %s at the last time: %d points %d cells, the whole frame %d points %d cells" %
              (series, da.GetNumberOfPoints(), da.GetNumberOfCells(), db.GetNumberOfPoints(), db.GetNumberOfCells()))
        if series == "particles":
            pa = sorted(da.GetPoints().GetPoint(i) for i in range(da.GetNumberOfPoints()))
            pb = sorted(db.GetPoints().GetPoint(i) for i in range(db.GetNumberOfPoints()))
            check(pa == pb, "2d-pieces: the particles of the last frame are not those of the whole frame")
        pv.Delete(a)
        pv.Delete(b)
    print("check_paraview: 2d-pieces: frames in per-rank pieces read by ParaView as the whole frames")

if failures:
    for f in failures[:30]:
        print("check_paraview: FAIL " + f)
    print("check_paraview: %d failures" % len(failures))
    sys.exit(1)
print("check_paraview: ParaView %s read all %d frames" % (sm.vtkSMProxyManager.GetParaViewSourceVersion().split()[-1],
                                                         sum(totals.values())))
PY
grep -v '^[[:space:]]*$' "$work/read.log" || true
[[ $status -eq 0 ]] || { echo "check_paraview: ParaView could not read lsdem's files (pvpython exit $status)" >&2; exit 1; }

# One screenshot per dimension through `lsdem paraview` (offscreen).
for run in 3d-compressed 2d-compressed; do
  png=$work/$run.png
  "$lsdem" paraview "$work/$run" --screenshot "$png" --size 600x400 2>&1 | grep -E '^(wrote|lsdem)' || true
  [[ -s $png ]] || { echo "check_paraview: lsdem paraview wrote no screenshot of $run" >&2; exit 1; }
  size=$(python3 -c 'import struct,sys; d=open(sys.argv[1],"rb").read(24); assert d[:8]==b"\x89PNG\r\n\x1a\n"; print("%dx%d" % struct.unpack(">II", d[16:24]))' "$png")
  [[ $size == 600x400 ]] || { echo "check_paraview: $run screenshot is $size, not 600x400" >&2; exit 1; }
done
echo "check_paraview: passed in $((SECONDS - start)) s"
