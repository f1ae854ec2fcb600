/// @file Scene.cpp
/// @brief `lsdem.Scene`: scene files, and scenes made from dicts (written as
/// TOML, then read by the same reader as the command line's).

#include "Bindings.h"

#include <pybind11/stl.h>
#include <toml++/toml.h>

#include <Python.h>

#include <climits>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>
#include <variant>

namespace lsdem::python {

namespace fs = std::filesystem;
using namespace pybind11::literals;

SceneHandle::~SceneHandle() {
  if (tempDir.empty()) return;
  std::error_code ec;
  fs::remove_all(tempDir, ec);
}

namespace {

std::string typeName(const py::handle& v) { return py::str(py::type::handle_of(v).attr("__name__")).cast<std::string>(); }

std::string dotted(const std::string& where, const std::string& key) { return where.empty() ? key : where + "." + key; }

// A TOML value converted from Python.
using Value = std::variant<toml::table, toml::array, std::int64_t, double, bool, std::string>;

Value valueOf(const py::handle& v, const std::string& where);

toml::table tableOf(const py::handle& mapping, const std::string& where) {
  toml::table t;
  for (const py::handle item : mapping.attr("items")()) {
    const py::tuple kv = py::reinterpret_borrow<py::tuple>(item);
    if (!py::isinstance<py::str>(kv[0])) {
      throw py::type_error("scene dict: " + dotted(where, py::repr(kv[0]).cast<std::string>()) +
                           ": keys must be strings, got a " + typeName(kv[0]));
    }
    const std::string key = kv[0].cast<std::string>();
    std::visit([&](auto&& value) { t.insert_or_assign(key, std::move(value)); }, valueOf(kv[1], dotted(where, key)));
  }
  return t;
}

Value valueOf(const py::handle& v, const std::string& where) {
  if (PyBool_Check(v.ptr())) return v.cast<bool>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (PyFloat_Check(v.ptr())) return v.cast<double>();
  if (PyLong_Check(v.ptr())) {
    int overflow = 0;
    const long long x = PyLong_AsLongLongAndOverflow(v.ptr(), &overflow);
    if (overflow != 0) throw py::value_error("scene dict: " + where + ": integer out of the 64-bit range");
    return std::int64_t(x);
  }
  if (PyDict_Check(v.ptr()) || (py::hasattr(v, "items") && py::hasattr(v, "keys"))) return tableOf(v, where);
  // numpy arrays and scalars: as the Python values they hold.
  if (py::hasattr(v, "tolist") && py::hasattr(v, "dtype")) return valueOf(v.attr("tolist")(), where);
  if (PyList_Check(v.ptr()) || PyTuple_Check(v.ptr())) {
    toml::array a;
    std::size_t k = 0;
    for (const py::handle item : v) {
      std::visit([&](auto&& value) { a.push_back(std::move(value)); },
                 valueOf(item, where + "[" + std::to_string(k++) + "]"));
    }
    return a;
  }
  if (py::hasattr(v, "__fspath__")) return py::str(v.attr("__fspath__")()).cast<std::string>();
  throw py::type_error("scene dict: " + where + ": a " + typeName(v) +
                       " has no TOML form (use dicts, lists, numbers, strings, booleans)");
}

std::string pathText(const py::handle& p) {
  if (py::isinstance<py::str>(p)) return p.cast<std::string>();
  if (py::hasattr(p, "__fspath__")) return py::str(p.attr("__fspath__")()).cast<std::string>();
  throw py::type_error("expected a path (str or os.PathLike), got a " + typeName(p));
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write the scene file " + path);
}

template <class F>
auto visitDef(const SceneHandle& s, F&& f) {
  return std::visit(std::forward<F>(f), *s.def);
}

// The names of a scene's planes or tools, in order.
template <class Range>
std::vector<std::string> namesOf(const Range& items) {
  std::vector<std::string> names;
  for (const auto& item : items) names.push_back(item.name);
  return names;
}

}  // namespace

std::string tomlText(const py::dict& scene) {
  const toml::table t = tableOf(scene, "");
  std::ostringstream out;
  out << toml::toml_formatter(t) << "\n";
  return out.str();
}

std::shared_ptr<SceneHandle> loadScene(const std::string& path) {
  auto s = std::make_shared<SceneHandle>();
  s->path = path;
  s->def = std::make_shared<const io::AnySceneDef>(io::readScene(path));
  return s;
}

std::shared_ptr<SceneHandle> sceneFromDict(const py::dict& d, const py::object& path) {
  const std::string text = tomlText(d);
  auto s = std::make_shared<SceneHandle>();
  if (path.is_none()) {
    s->tempDir = py::module_::import("tempfile").attr("mkdtemp")("prefix"_a = "lsdem-scene-").cast<std::string>();
    s->path = (fs::path(s->tempDir) / "scene.toml").string();
  } else {
    s->path = pathText(path);
  }
  writeText(s->path, text);
  s->def = std::make_shared<const io::AnySceneDef>(io::readScene(s->path));
  return s;
}

std::shared_ptr<SceneHandle> sceneOf(const py::handle& scene) {
  if (py::isinstance<SceneHandle>(scene)) return scene.cast<std::shared_ptr<SceneHandle>>();
  if (PyDict_Check(scene.ptr())) return sceneFromDict(py::reinterpret_borrow<py::dict>(scene), py::none());
  return loadScene(pathText(scene));
}

void bindScene(py::module_& m) {
  py::class_<SceneHandle, std::shared_ptr<SceneHandle>>(m, "Scene", R"doc(
A scene: a TOML scene file (docs/scenes.md), read and checked as `lsdem run` reads it.

Scene(path) reads the file; Scene.from_dict(d, path=None) writes a dict of the
same structure as TOML and reads that. Bad input raises lsdem.InputError
("FILE:LINE: KEY: problem").
)doc")
      .def(py::init([](const py::object& path) { return loadScene(pathText(path)); }), py::arg("path"),
           "Reads and checks the scene file `path` and builds its shapes.")
      .def_static("from_dict", &sceneFromDict, py::arg("scene"), py::arg("path") = py::none(),
          R"doc(A scene from a dict of the TOML file's structure (tables as dicts, [[arrays]] as
lists of dicts). It is written as TOML to `path` (kept), or without a path to a
temporary folder removed when the Scene is freed; relative file names inside
(meshes, grain files) are relative to that file's folder, so give absolute
ones or a `path` beside them. Errors name that file's lines.)doc")
      .def_static("toml", &tomlText, py::arg("scene"), "The TOML text from_dict writes for `scene`.")
      .def_property_readonly("path", [](const SceneHandle& s) { return s.path; }, "The scene file.")
      .def_property_readonly("dimension", &SceneHandle::dimension, "2 or 3.")
      .def_property_readonly(
          "duration", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.duration; }); },
          "[simulation] duration, s (0 when the scene gives steps).")
      .def_property_readonly(
          "steps",
          [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return std::uint64_t(d.steps); }); },
          "[simulation] steps (0 when the scene gives a duration).")
      .def_property_readonly(
          "threads", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.threads; }); },
          "[simulation] threads (0: all cores).")
      .def_property_readonly(
          "output_dir", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.output.dir; }); },
          "[output] dir.")
      .def_property_readonly(
          "notes", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.notes; }); },
          "What reading the scene left out, one line each.")
      .def_property_readonly(
          "shape_names", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.shapeNames; }); },
          "Names of the [shapes] tables, in file order.")
      .def_property_readonly(
          "materials", [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.materials; }); },
          "Material names; a particle's material is its index here.")
      .def_property_readonly(
          "planes",
          [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return namesOf(d.planes); }); },
          "Names of the planes, in order.")
      .def_property_readonly(
          "tools",
          [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return namesOf(d.tools); }); },
          "Names of the tools, in order.")
      .def_property_readonly(
          "has_breakage",
          [](const SceneHandle& s) { return visitDef(s, [](const auto& d) { return d.breakage.has_value(); }); },
          "True when the scene declares [effects.breakage].")
      .def("__repr__", [](const SceneHandle& s) {
        return "<lsdem.Scene " + std::to_string(s.dimension()) + "D '" + s.path + "'>";
      });
}

}  // namespace lsdem::python
