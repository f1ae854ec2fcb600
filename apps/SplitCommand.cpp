/// @file SplitCommand.cpp
/// @brief `lsdem split FILE.toml --plane nx,ny[,nz],d [--json]`: splits the
/// shape a `[shape]` table declares by the plane n . x = d (in the frame the
/// shape was declared in) with level-set splitting (eq. 14-16) and prints each
/// fragment and the mass balance.

#include "Commands.h"

#include "lsdem/breakage/Split.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/JsonWriter.h"
#include "lsdem/io/ShapeFile.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

struct SplitOptionsCli {
  std::string file;
  std::string plane;
  bool json = false;
  double regridCells = 0.0;
  std::string regridNodes = "parent_spacing";
};

// "nx,ny[,nz],d" -> D + 1 finite numbers, or a one-line error.
std::vector<double> parsePlane(const std::string& text, int dimension) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    // (strtod: a number too small for a normal double, 1e-320, is one
    // still; std::stod refused it.)
    char* end = nullptr;
    const double v = item.empty() ? 0.0 : std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size()) {
      throw io::InputError("--plane", 0, "", "'" + item + "' is not a number");
    }
    if (!std::isfinite(v)) throw io::InputError("--plane", 0, "", "'" + item + "' is not a finite number");
    values.push_back(v);
  }
  if (int(values.size()) != dimension + 1) {
    throw io::InputError("--plane", 0, "",
                         "a " + std::to_string(dimension) + "D plane needs " + std::to_string(dimension + 1) +
                             " numbers nx,ny" + (dimension == 3 ? ",nz" : "") + ",d; got " +
                             std::to_string(values.size()));
  }
  return values;
}

template <int D>
void runSplit(const io::ShapeDecl& decl, const SplitOptionsCli& opts) {
  const std::vector<double> p = parsePlane(opts.plane, D);
  geometry::Vec<D> n;
  for (int a = 0; a < D; ++a) n[a] = p[std::size_t(a)];
  // Normalised (as a scene's normals: components near the ends of the
  // double range keep their direction), the offset with it.
  const double length = n.stableNorm();
  if (!(length > 0.0)) throw io::InputError("--plane", 0, "", "the plane normal is zero");
  n /= length;
  const double d = p[std::size_t(D)] / length;
  if (!std::isfinite(d) || !n.allFinite()) {
    throw io::InputError("--plane", 0, "", "the plane n.x = d lies farther than any shape can reach (d / |n| overflows)");
  }

  const std::shared_ptr<const geometry::Shape<D>> shape = io::buildDeclaredShape<D>(decl);
  // The plane n . x = d in the declared (grid) frame, moved to the body frame:
  // x = R x_b + c gives (R^T n) . x_b = d - n . c.
  const geometry::Rigid<D>& toGrid = shape->bodyToGrid();
  breakage::FractureSurface<D> surface;
  surface.plane = geometry::HalfSpace<D>{geometry::Vec<D>(toGrid.rotation.transpose() * n), d - n.dot(toGrid.translation)};
  breakage::SplitOptions splitOptions;
  splitOptions.regridCells = opts.regridCells;
  // (As a scene's breakage: the split's nodes were per new cell, 16206 for a
  // cap of a 1744-node sphere, where a run's keep the parent's spacing.)
  splitOptions.regridKeepsNodeSpacing = opts.regridNodes == "parent_spacing";
  const breakage::SplitResult<D> result = breakage::splitShape(*shape, surface, splitOptions);
  // The volume each fragment's own zero level set encloses (as the surfaces
  // output draws it): its mass should be rho times this.
  std::vector<double> enclosed;
  double correctedSum = 0.0;
  for (const auto& f : result.fragments) {
    enclosed.push_back(geometry::enclosedVolume<D>(f.shape->grid()));
    correctedSum += f.volume;
  }
  // (A plane that does not split the shape leaves it whole: its volume.)
  if (!result.isSplit) correctedSum = result.parentVolume;
  auto centroidOf = [&](const breakage::Fragment<D>& f) { return toGrid.apply(f.childToParent.translation); };

  if (opts.json) {
    io::JsonWriter w(std::cout);
    w.beginObject().field("dimension", D).field("split", result.isSplit).key("fragments").beginArray();
    for (std::size_t k = 0; k < result.fragments.size(); ++k) {
      const auto& f = result.fragments[k];
      w.beginObject()
          .field("volume", f.volume)
          .field("grid_volume", f.rawVolume)
          .field("enclosed_volume", enclosed[k])
          .field("regridded", f.regridded)
          .field("centroid", centroidOf(f))
          .field("nodes", f.shape->nodes().size())
          .field("side", f.side)
          .endObject();
    }
    w.endArray()
        .field("parent_volume", result.parentVolume)
        .field("share_error", result.rawRelativeError)
        .field("volume_sum", correctedSum)
        .field("dropped_fragments", result.droppedCount)
        .endObject();
    return;
  }
  std::printf("split %s (%dD) by n.x = d with n = (", opts.file.c_str(), D);
  for (int a = 0; a < D; ++a) std::printf("%s%g", a ? ", " : "", n[a]);
  std::printf("), d = %g\n", d);
  std::printf("  parent %s %.9g\n", D == 2 ? "area" : "volume", result.parentVolume);
  if (!result.isSplit) std::printf("  the plane does not split the shape\n");
  for (std::size_t k = 0; k < result.fragments.size(); ++k) {
    const auto& f = result.fragments[k];
    const geometry::Vec<D> c = centroidOf(f);
    std::printf("  fragment %zu: %s %.9g (its own grid gives %.9g%s), centroid (", k, D == 2 ? "area" : "volume",
                f.volume, f.rawVolume, f.regridded ? ", re-gridded" : "");
    for (int a = 0; a < D; ++a) std::printf("%s%.6g", a ? ", " : "", c[a]);
    std::printf("), %zu nodes; its surface encloses %.9g (%+.2f %%)\n", f.shape->nodes().size(), enclosed[k],
                100.0 * (f.volume / enclosed[k] - 1.0));
  }
  std::printf("  share quadrature error %.3e (relative, removed); sum %.9g\n", result.rawRelativeError, correctedSum);
}

}  // namespace

void addSplitCommand(CLI::App& app) {
  auto opts = std::make_shared<SplitOptionsCli>();
  CLI::App* cmd = app.add_subcommand("split", "Split the shape of a [shape] table by a plane (level-set splitting)");
  cmd->add_option("file", opts->file, "TOML file with a [shape] table (keys: docs/shapes.md)")->required();
  cmd->add_option("--plane", opts->plane, "the plane n.x = d as nx,ny[,nz],d in the shape's frame, metres")->required();
  cmd->add_option("--regrid-cells", opts->regridCells,
                  "re-grid a fragment thinner than this many parent cells ([effects.breakage] regrid_cells; 0: off)")
      ->check(atLeast<false>(0, 1000));
  cmd->add_option("--regrid-nodes", opts->regridNodes,
                  "a re-gridded fragment's nodes: parent_spacing (default, as a scene's) or per_new_cell "
                  "([effects.breakage] regrid_nodes)")
      ->check(CLI::IsMember({"parent_spacing", "per_new_cell"}));
  cmd->add_flag("--json", opts->json, "Print JSON instead of text");
  cmd->callback([opts] {
    const io::ShapeDecl decl = io::readShapeFile(opts->file);
    if (decl.dimension() == 2) {
      runSplit<2>(decl, *opts);
    } else {
      runSplit<3>(decl, *opts);
    }
  });
}

}  // namespace lsdem::apps
