/// @file Module.cpp
/// @brief The `lsdem` Python module (docs/python.md): errors, `run` (the
/// command line's `lsdem run`, io::runScene), the ParaView readers, and the
/// Scene and Simulation classes (Scene.cpp, Simulation.cpp).

#include "Bindings.h"

#include "lsdem/io/InputError.h"
#include "lsdem/io/Run.h"
#include "lsdem/io/VtpRead.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <Python.h>

#include <atomic>
#include <cctype>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace lsdem::python {

using namespace pybind11::literals;

namespace {

// lsdem.InputError, a ValueError carrying the location (file, line, key).
PyObject* inputErrorType = nullptr;

void raiseInputError(const io::InputError& e) {
  py::object type = py::reinterpret_borrow<py::object>(inputErrorType);
  py::object exc = type(e.what());
  exc.attr("file") = e.file();
  exc.attr("line") = e.line();
  exc.attr("key") = e.key();
  exc.attr("problem") = e.problem();
  PyErr_SetObject(inputErrorType, exc.ptr());
}

// A run's advice names command-line options; from Python they are run()'s
// arguments ("give --overwrite" -> "give overwrite=True"). Only an option
// at a word's start (the text's start, after a space or a parenthesis) and
// ending there is rewritten: a path or name holding "--" is left alone.
std::string pythonSpelling(const std::string& text) {
  static const std::pair<std::string_view, std::string_view> names[] = {
      {"--overwrite", "overwrite=True"}, {"--force", "force=True"}, {"--resume ", "resume="},
      {"--steps N", "steps=N"},          {"--resume", "resume"},    {"--steps", "steps"},
      {"--out", "out"},                  {"--threads", "threads"}};
  std::string out;
  for (std::size_t at = 0; at < text.size();) {
    bool replaced = false;
    if ((at == 0 || text[at - 1] == ' ' || text[at - 1] == '(') && text.compare(at, 2, "--") == 0) {
      for (const auto& [cli, python] : names) {
        const std::size_t end = at + cli.size();
        if (text.compare(at, cli.size(), cli) != 0) continue;
        const bool ends = cli.back() == ' ' || end == text.size() ||
                          !(std::isalnum(static_cast<unsigned char>(text[end])) || text[end] == '-' || text[end] == '_');
        if (!ends) continue;
        out += python;
        at = end;
        replaced = true;
        break;
      }
    }
    if (!replaced) out += text[at++];
  }
  return out;
}

}  // namespace

int checkedThreads(const py::handle& threads) {
  const long long n = threads.cast<long long>();
  if (n < 0 || n > io::kMaxThreads) {
    throw py::value_error("threads must be in [0, " + std::to_string(io::kMaxThreads) + "] (0: all cores), got " +
                          std::to_string(n));
  }
  return int(n);
}

namespace {

std::string pathText(const py::handle& p) {
  if (py::isinstance<py::str>(p)) return p.cast<std::string>();
  if (py::hasattr(p, "__fspath__")) return py::str(p.attr("__fspath__")()).cast<std::string>();
  throw py::type_error("expected a path (str or os.PathLike)");
}

py::dict progressDict(const io::RunProgress& p) {
  py::dict d;
  d["steps"] = p.steps;
  d["time"] = p.time;
  d["end_time"] = p.endTime;
  d["fraction"] = p.fraction;
  d["steps_per_second"] = p.stepsPerSecond;
  d["wall_seconds"] = p.wallSeconds;
  d["eta_seconds"] = p.etaSeconds;
  d["particles"] = p.particles;
  d["contacts"] = p.contacts;
  d["breakages"] = p.breakages;
  d["done"] = p.done;
  return d;
}

py::dict run(const py::object& scene, const py::object& out, const py::object& steps, const py::object& threads,
             bool overwrite, const py::object& resume, bool force, bool check, const py::object& progress) {
  io::RunOptions o;
  std::shared_ptr<SceneHandle> fromDict;  // a dict's scene file, kept for the run
  if (PyDict_Check(scene.ptr())) {
    fromDict = sceneFromDict(py::reinterpret_borrow<py::dict>(scene), py::none());
    o.scene = fromDict->path;
  } else if (!scene.is_none()) {
    o.scene = py::isinstance<SceneHandle>(scene) ? scene.cast<const SceneHandle&>().path : pathText(scene);
  }
  if (!out.is_none()) o.outDir = pathText(out);
  if (!steps.is_none()) o.steps = steps.cast<std::uint64_t>();
  if (!threads.is_none()) o.threads = checkedThreads(threads);
  if (!resume.is_none()) o.resumeDir = pathText(resume);
  if (o.scene.empty() && o.resumeDir.empty()) throw py::value_error("run: give a scene, or resume=FOLDER");
  o.overwrite = overwrite;
  o.force = force;
  o.check = check;

  // Progress reports come from inside the run, GIL released: each takes the
  // GIL to look for Ctrl-C and to call `progress`; either stops the run
  // after the current step (checkpoint, summary and last frame written).
  std::atomic<bool> stop{false};
  std::optional<py::error_already_set> failure;
  std::vector<std::string> notes;
  o.stop = &stop;
  o.progress = [&](const io::RunProgress& p) {
    py::gil_scoped_acquire acquire;
    if (failure) return;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!progress.is_none()) progress(progressDict(p));
    } catch (py::error_already_set& e) {
      failure.emplace(std::move(e));
      stop = true;
    }
  };
  o.note = [&](const std::string& line) { notes.push_back(line); };

  io::RunResult r;
  {
    py::gil_scoped_release release;
    try {
      r = io::runScene(o);
    } catch (const io::InputError& e) {
      throw io::InputError(e.file(), e.line(), e.key(), pythonSpelling(e.problem()));
    }
  }
  if (failure) throw std::move(*failure);
  py::dict d;
  d["out_dir"] = r.outDir;
  d["dimension"] = r.dimension;
  d["steps"] = r.steps;
  d["time"] = r.time;
  d["wall_seconds"] = r.wallSeconds;
  d["stopped"] = r.stopped;
  d["particles"] = r.particles;
  d["breakages"] = r.breakages;
  d["mass_in"] = r.massIn;
  d["mass_out"] = r.massOut;
  d["mass_balance_error"] = r.massBalanceError;
  d["notes"] = notes;
  return d;
}

// One VTK array as numpy: (tuples,) or (tuples, components).
py::array arrayOf(const io::VtkArray& a) {
  return std::visit(
      [&](const auto& v) -> py::array {
        using T = typename std::decay_t<decltype(v)>::value_type;
        const std::size_t n = a.components > 0 ? v.size() / std::size_t(a.components) : 0;
        std::vector<py::ssize_t> shape{py::ssize_t(n)};
        if (a.components != 1) shape.push_back(a.components);
        py::array_t<T> out(shape);
        std::copy(v.begin(), v.end(), out.mutable_data());
        return out;
      },
      a.values);
}

py::dict cellsOf(const io::VtkCells& c) {
  py::dict d;
  d["connectivity"] = py::array_t<std::int64_t>(py::ssize_t(c.connectivity.size()), c.connectivity.data());
  d["offsets"] = py::array_t<std::int64_t>(py::ssize_t(c.offsets.size()), c.offsets.data());
  return d;
}

py::dict readVtp(const py::object& path) {
  const io::VtpPiece piece = io::readVtp(pathText(path));
  py::dict d;
  py::array_t<double> points({py::ssize_t(piece.pointCount()), py::ssize_t(3)});
  std::copy(piece.points.begin(), piece.points.end(), points.mutable_data());
  d["points"] = points;
  d["verts"] = cellsOf(piece.verts);
  d["lines"] = cellsOf(piece.lines);
  d["polys"] = cellsOf(piece.polys);
  py::dict pointData, cellData;
  for (const io::VtkArray& a : piece.pointData) pointData[py::str(a.name)] = arrayOf(a);
  for (const io::VtkArray& a : piece.cellData) cellData[py::str(a.name)] = arrayOf(a);
  d["point_data"] = pointData;
  d["cell_data"] = cellData;
  return d;
}

}  // namespace

}  // namespace lsdem::python

PYBIND11_MODULE(lsdem, m) {
  namespace py = pybind11;
  using namespace lsdem::python;
  m.doc() = "lsdem: the Level Set Discrete Element Method with particle breakage, 2D and 3D (docs/python.md).";
  m.attr("__version__") = LSDEM_VERSION;

  static py::exception<lsdem::io::InputError> inputError(m, "InputError", PyExc_ValueError);
  inputError.doc() =
      "Bad input (scene, shape, grain or mesh file, checkpoint, output folder): str(e) is the one line "
      "'FILE:LINE: KEY: problem' the command line prints; e.file, e.line (0: unknown), e.key, e.problem.";
  inputErrorType = inputError.ptr();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const lsdem::io::InputError& e) {
      raiseInputError(e);
    }
  });

  bindScene(m);
  bindSimulation(m);

  m.def("run", &run, py::arg("scene") = py::none(), py::kw_only(), py::arg("out") = py::none(),
        py::arg("steps") = py::none(), py::arg("threads") = py::none(), py::arg("overwrite") = false,
        py::arg("resume") = py::none(), py::arg("force") = false, py::arg("check") = false,
        py::arg("progress") = py::none(),
        R"doc(Runs (or resumes) a scene and writes every output `lsdem run` writes
(docs/outputs.md): the same code as the command line. The GIL is released.

scene: lsdem.Scene, dict (as Scene.from_dict takes) or path (None with resume=). out: output folder (None: the
scene's [output] dir). steps: run this many steps instead of the scene's end.
threads: OpenMP threads (None: the scene's; 0: all cores). overwrite: replace
another run's outputs. resume: continue the run in this folder. force: resume
with another scene. check: `--check`. progress: called with a dict every
[output] progress_seconds and at the end (Ctrl-C is noticed then too: the run
stops after writing its checkpoint, then KeyboardInterrupt is raised).

Returns a dict: out_dir, dimension, steps, time, wall_seconds, stopped,
particles, breakages, mass_in, mass_out, mass_balance_error, notes.)doc");

  m.def("read_vtp", &readVtp, py::arg("path"),
        R"doc(Reads a VTK XML PolyData file (.vtp) as lsdem writes it: a dict with points
(n, 3) float64, verts / lines / polys ({connectivity, offsets} int64), and
point_data / cell_data (name -> array, (n,) or (n, components))).)doc");
  m.def(
      "read_pvd",
      [](const py::object& path) {
        py::list out;
        for (const auto& e : lsdem::io::readPvd(pathText(path))) out.append(py::make_tuple(e.time, e.file));
        return out;
      },
      py::arg("path"), "The (time, file) entries of a ParaView series (.pvd); files relative to its folder.");
  m.def("toml", &tomlText, py::arg("scene"), "The TOML text of a scene dict (what Scene.from_dict writes).");
}
