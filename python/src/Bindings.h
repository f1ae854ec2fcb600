#pragma once
/// @file Bindings.h
/// @brief Private to the Python module (docs/python.md): the scene handle the
/// module's functions share, and the functions that add each part of the
/// module.

#include "lsdem/io/Scene.h"

#include <pybind11/pybind11.h>

#include <memory>
#include <string>

namespace lsdem::python {

namespace py = pybind11;

/// A scene read from a file (`lsdem.Scene`): the file stays where it is; a
/// scene made from a dict without a path lives in a temporary folder of its
/// own, removed with the handle.
struct SceneHandle {
  std::string path;                             ///< the scene file readScene read
  std::shared_ptr<const io::AnySceneDef> def;   ///< what it declares
  std::string tempDir;                          ///< non-empty: removed with the handle

  SceneHandle() = default;
  SceneHandle(const SceneHandle&) = delete;
  SceneHandle& operator=(const SceneHandle&) = delete;
  ~SceneHandle();

  int dimension() const { return def->index() == 0 ? 2 : 3; }
};

/// @brief The TOML text of a scene given as a dict of the file's structure
/// (tables as dicts, arrays of tables as lists of dicts, numbers, strings,
/// booleans, lists and numpy arrays).
/// @note Throws py::type_error naming the dotted key of a value with no TOML form.
std::string tomlText(const py::dict& scene);

/// @brief `threads` as run() and Simulation take it: a whole number in
/// [0, io::kMaxThreads] (0: all cores); else py::value_error.
int checkedThreads(const py::handle& threads);

/// @brief Reads a scene file (io::InputError for bad input).
std::shared_ptr<SceneHandle> loadScene(const std::string& path);

/// @brief A scene from a dict (Scene.from_dict): written as TOML to `path`,
/// or when it is None to a temporary folder the handle removes.
std::shared_ptr<SceneHandle> sceneFromDict(const py::dict& scene, const py::object& path);

/// @brief A scene handle from `scene`: a Scene, a dict (sceneFromDict), or a
/// path (str or os.PathLike).
std::shared_ptr<SceneHandle> sceneOf(const py::handle& scene);

void bindScene(py::module_& m);
void bindSimulation(py::module_& m);

}  // namespace lsdem::python
