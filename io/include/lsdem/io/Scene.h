#pragma once
/// @file Scene.h
/// @brief Scene files (TOML): what a run simulates and writes. Every key is
/// documented in docs/scenes.md. readScene() checks the whole file and builds
/// its shapes; buildWorld() places the particles and assembles a world from the
/// effects the scene declares, and nothing else.

#include "lsdem/breakage/Breakage.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/io/Vtk.h"

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace lsdem::io {

/// How a particle group is placed.
enum class Placement {
  List,   ///< explicit positions
  Cloud,  ///< random, non-overlapping (bounding spheres) in a region
  Grid,   ///< on a lattice filling a region
  Feed,   ///< dropped one at a time from a point during the run
};

/// One `[[particles]]` group.
template <int D>
struct ParticleGroupDef {
  int line = 0;                          ///< line of the group in the file (messages)
  std::vector<std::size_t> shapes;       ///< indices into SceneDef::shapes, cycled in order
  double density = 2650.0;               ///< kg/m^3 (kg/m^2 per unit thickness in 2D)
  int material = 0;                      ///< index into SceneDef::materials
  Placement placement = Placement::List;
  std::vector<geometry::Vec<D>> positions;  ///< List: centroids, m
  std::vector<double> angles;               ///< List, 2D: orientation angles of the principal frame, rad (empty: 0)
  std::vector<geometry::Mat<D>> rotations;  ///< List, 3D: rotations of the principal frame (empty: identity)
  geometry::Box<D> region;                  ///< Cloud, Grid: centroids stay in here, bodies inside it, m
  std::uint64_t count = 0;                  ///< Cloud, Grid: particles; Feed: grains in all (0 = no limit)
  double gridSpacing = 0.0;                 ///< Grid: lattice spacing, m (0: the largest bounding diameter)
  bool randomOrientation = false;           ///< Cloud, Grid: uniformly random orientations
  /// Scale each particle's shape to a random equivalent diameter, uniform in
  /// [min, max] (m); {0, 0}: shapes as defined.
  double diameterMin = 0.0, diameterMax = 0.0;
  geometry::Vec<D> velocity = geometry::Vec<D>::Zero();  ///< initial velocity, m/s
  std::uint64_t seed = 1;                   ///< random placement, orientations and sizes
  // Feed
  geometry::Vec<D> feedPoint = geometry::Vec<D>::Zero();  ///< m
  double feedInterval = 0.0;                ///< s; 0: when the last grain has cleared
  double feedClearance = 0.0;               ///< m
  double feedStart = 0.0;                   ///< s
};

/// What the run writes and how often (`[output]`).
struct OutputDef {
  std::string dir = "lsdem-out";        ///< output folder (the command line's --out wins)
  std::uint64_t frames = 50;            ///< ParaView frames over the run (0: none), including the first and the last
  bool particles = true, surfaces = true, boundaries = true, contacts = false;  ///< ParaView series written
  VtkEncoding vtkFormat = VtkEncoding::Compressed;  ///< how VTP arrays are stored (`vtk_format`; io/Vtk.h)
  /// A distributed run's frames of particles, surfaces and contacts: each
  /// rank writes its own particles' piece and the frame is a `.pvtp` of the
  /// pieces (`frame_pieces = "ranks"`), or rank 0 writes the whole frame
  /// from its view of the run (false, `"gathered"`: the default). One
  /// process writes whole frames either way.
  bool framePiecesPerRank = false;
  std::uint64_t historyRows = 500;      ///< rows of history.csv over the run
  std::uint64_t distributions = 5;      ///< PSD and shape-statistics snapshots over the run (including the first and last)
  std::vector<double> distributionTimes;  ///< instead: snapshots at these simulated times, s (ascending), plus the first and last
  /// Shape statistics (circularity / sphericity, aspect ratio) leave out
  /// particles whose equivalent diameter is below this many cells of their
  /// own grid: a fragment a few cells across has no resolved shape (its
  /// sphericity from the grid's volume and the nodes' area can exceed 1).
  double shapeMinCells = 5.0;
  double checkpointEvery = 0.0;         ///< s of simulated time between checkpoints (0: only at the end)
  /// Global ids of the particles whose trajectory tracks.csv records (`track`; empty: no tracks.csv).
  std::vector<std::uint64_t> track;
  double trackEvery = 0.0;              ///< s of simulated time between rows of tracks.csv (0: every step)
  double progressSeconds = 2.0;         ///< wall seconds between progress reports
};

/// A specimen whose stress, strain and void ratio the history records
/// (`[output.specimen]`): the space between two boundaries.
struct SpecimenDef {
  std::string top;       ///< plane or tool that loads the specimen
  std::string bottom;    ///< plane it is loaded against
  double width = 0.0;    ///< 2D: specimen width, m; 3D: cross-section area, m^2
};

/// How a run spread over MPI ranks keeps its work balanced (`[parallel]`,
/// docs/scenes.md; docs/parallel.md). A one-process run ignores it.
struct ParallelDef {
  /// A rank's load (`balance`): its particles' surface nodes, or (true) the
  /// wall time of its own work, spread over its particles by their nodes.
  bool balanceByTime = false;
  /// Rebuild the decomposition when the most loaded rank's load exceeds
  /// this times the mean; 0: never.
  double rebalanceImbalance = 1.25;
  std::uint64_t rebalanceEvery = 200;  ///< steps between two checks of the imbalance
};

/// The most OpenMP threads a scene, the command line or Python may ask for.
inline constexpr int kMaxThreads = 4096;

/// A whole scene of dimension D.
template <int D>
struct SceneDef {
  std::string file;                      ///< the scene file
  double duration = 0.0;                 ///< s (exactly one of duration and steps is > 0)
  std::uint64_t steps = 0;
  int threads = 0;                       ///< OpenMP threads, 0: all cores
  std::uint64_t seed = 1;
  dynamics::WorldDef<D> world;           ///< contact law, time step, gravity, damping, outflow, finite checks
  std::vector<std::string> shapeNames;   ///< `[shapes.NAME]`, in file order; a folder adds NAME/FILE
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes;
  std::vector<std::string> materials;    ///< names, index = material id
  std::vector<ParticleGroupDef<D>> groups;
  std::vector<dynamics::PlaneDef<D>> planes;
  std::vector<dynamics::ToolDef<D>> tools;
  std::optional<breakage::BreakageDef<D>> breakage;
  OutputDef output;
  ParallelDef parallel;
  std::optional<SpecimenDef> specimen;
  /// The region drawn for planes in ParaView and used for the default output
  /// extent, m (from `[simulation] domain`, or the particles' and tools' box).
  std::optional<geometry::Box<D>> domain;
  /// Lines of the keys that are checked once the world is built (dotted key
  /// -> line in `file`), for messages: `simulation.duration`,
  /// `output.checkpoint_every`, `effects.gravity`, velocities.
  std::map<std::string, int> keyLines;
  /// What reading the scene left out, one line each ("FILE:LINE: KEY: mesh
  /// 'wall.stl': 2 zero-area faces dropped ..."): `lsdem run` prints them.
  std::vector<std::string> notes;
};

using AnySceneDef = std::variant<SceneDef<2>, SceneDef<3>>;

/// @brief Reads and checks a scene file and builds its shapes.
/// @note Throws InputError ("file:line: key: problem") for any bad input:
/// syntax, unknown keys, wrong types, out-of-range values, unknown names.
AnySceneDef readScene(const std::string& path);

/// A world assembled from a scene, with handles on the effects a run reports.
template <int D>
struct SceneWorld {
  std::unique_ptr<dynamics::World<D>> world;
  breakage::Breakage<D>* breakage = nullptr;     ///< null when the scene has no breakage
  std::vector<dynamics::Feed<D>*> feeds;         ///< one per feed group
  double initialMass = 0.0;                      ///< kg of the particles placed at the start
};

/// @brief Places the scene's particles (deterministic for its seeds) and
/// assembles the world: planes, tools, then effects in this order: gravity,
/// global damping, local damping, breakage, outflow, feeds.
/// @note Throws InputError when a group cannot be placed (a region too small
/// for its count, a particle outside it).
template <int D>
SceneWorld<D> buildWorld(const SceneDef<D>& scene);

/// @brief A shape scaled by `factor` about its centroid: grid, nodes, mass
/// properties and descriptors scaled exactly (no resampling).
template <int D>
std::shared_ptr<const geometry::Shape<D>> scaledShape(const geometry::Shape<D>& shape, double factor);

}  // namespace lsdem::io
