// Scene files: what they build (placement, tools, effects) and how bad input
// is reported (one line with file, line and key; exit code 2 from lsdem run).

#include "support/Files.h"
#include "lsdem/io/GrainFile.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>

using namespace lsdem;
namespace fs = std::filesystem;

namespace {

const char* kBase = R"([simulation]
dimension = 2
steps = 10

[contact]
kn = 1e5

[materials.rock]
density = 2000.0

[shapes.disc]
kind = "circle"
radius = 0.01
cells_across = 16

[[particles]]
shape = "disc"
material = "rock"
placement = "list"
positions = [[0.0, 0.05], [0.03, 0.05]]
)";

fs::path writeScene(const std::string& name, const std::string& text) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_scene");
  fs::create_directories(dir);
  const fs::path p = dir / (name + ".toml");
  std::ofstream(p) << text;
  return p;
}

// Replaces the first occurrence of `from` in the base scene.
std::string edit(const std::string& from, const std::string& to) {
  std::string s = kBase;
  const std::size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

template <int D>
const io::SceneDef<D>& as(const io::AnySceneDef& s) {
  return std::get<io::SceneDef<D>>(s);
}

struct BadCase {
  std::string name;
  std::string scene;
  int line;
  std::string key;
  std::string message;  // a part of the problem text
};

}  // namespace

TEST(Scene, ReadsTheBaseScene) {
  const io::AnySceneDef any = io::readScene(writeScene("base", kBase).string());
  const auto& s = as<2>(any);
  EXPECT_EQ(s.steps, 10u);
  EXPECT_EQ(s.world.contact.kn, 1e5);
  EXPECT_FALSE(s.world.contact.hasFriction);  // not declared: not built
  EXPECT_FALSE(s.world.contact.hasDamping);
  EXPECT_FALSE(s.world.gravity);
  ASSERT_EQ(s.groups.size(), 1u);
  EXPECT_EQ(s.groups[0].density, 2000.0);
  const io::SceneWorld<2> w = io::buildWorld(s);
  ASSERT_EQ(w.world->particles().size(), 2u);
  EXPECT_EQ(w.world->particles().id[1], 1u);
  EXPECT_EQ(w.world->particles().position[1], geometry::Vec<2>(0.03, 0.05));
  EXPECT_TRUE(w.world->effectNames().empty());
  EXPECT_NEAR(w.initialMass, 2.0 * 2000.0 * std::acos(-1.0) * 1e-4, 2e-3 * w.initialMass);
}

TEST(Scene, ParallelSettings) {
  const auto base = as<2>(io::readScene(writeScene("parallel_default", kBase).string()));
  EXPECT_EQ(base.parallel.rebalanceImbalance, 1.25);
  EXPECT_EQ(base.parallel.rebalanceEvery, 200u);
  EXPECT_FALSE(base.parallel.balanceByTime);
  const auto set = as<2>(io::readScene(
      writeScene("parallel_set", std::string(kBase) +
                                     "[parallel]\nbalance = \"time\"\nrebalance_imbalance = 0\nrebalance_every = 50\n")
          .string()));
  EXPECT_EQ(set.parallel.rebalanceImbalance, 0.0);
  EXPECT_EQ(set.parallel.rebalanceEvery, 50u);
  EXPECT_TRUE(set.parallel.balanceByTime);
  // Frames: gathered by default, or in per-rank pieces.
  EXPECT_FALSE(base.output.framePiecesPerRank);
  const auto pieces =
      as<2>(io::readScene(writeScene("frame_pieces", std::string(kBase) + "[output]\nframe_pieces = \"ranks\"\n").string()));
  EXPECT_TRUE(pieces.output.framePiecesPerRank);
}

TEST(Scene, FrictionFromAStartTime) {
  const std::string scene = edit("kn = 1e5", "kn = 1e5\nfriction = 0.3\nfriction_from = 0.25");
  const auto any = io::readScene(writeScene("friction_from", scene).string());
  const auto& s = as<2>(any);
  EXPECT_TRUE(s.world.contact.hasFriction);
  EXPECT_EQ(s.world.contact.friction, 0.3);
  EXPECT_EQ(s.world.contact.frictionFrom, 0.25);
  const auto plain = io::readScene(writeScene("plain", edit("kn = 1e5", "kn = 1e5\nfriction = 0.3")).string());
  EXPECT_EQ(as<2>(plain).world.contact.frictionFrom, 0.0);  // from the start
}

TEST(Scene, EveryBadInputIsOneLineWithFileLineAndKey) {
  const std::vector<BadCase> cases = {
      {"negative_kn", edit("kn = 1e5", "kn = -1e5"), 6, "contact.kn", "must be positive"},
      {"negative_friction", edit("kn = 1e5", "kn = 1e5\nfriction = -0.2"), 7, "contact.friction", "must be >= 0"},
      {"friction_from_alone", edit("kn = 1e5", "kn = 1e5\nfriction_from = 0.1"), 7, "contact.friction_from",
       "needs `friction`"},
      {"negative_friction_from", edit("kn = 1e5", "kn = 1e5\nfriction = 0.3\nfriction_from = -1.0"), 8,
       "contact.friction_from", "must be >= 0"},
      {"dt_zero", edit("steps = 10", "steps = 10\ndt = 0.0"), 4, "simulation.dt", "must be positive"},
      {"dt_word", edit("steps = 10", "steps = 10\ndt = \"fast\""), 4, "simulation.dt", "\"auto\""},
      {"nan_density", edit("density = 2000.0", "density = nan"), 9, "materials.rock.density", "finite"},
      {"unknown_key", edit("steps = 10", "steps = 10\nstpes = 3"), 4, "simulation.stpes", "unknown key"},
      {"wrong_type", edit("radius = 0.01", "radius = \"big\""), 13, "shapes.disc.radius", "expected a number"},
      {"unknown_shape", edit("shape = \"disc\"", "shape = \"dsic\""), 17, "particles[0].shape", "no shape named 'dsic'"},
      {"unknown_material", edit("material = \"rock\"", "material = \"granite\""), 18, "particles[0].material",
       "no material named"},
      {"both_end", edit("steps = 10", "steps = 10\nduration = 1.0"), 3, "simulation.steps", "exactly one"},
      {"bad_dimension", edit("dimension = 2", "dimension = 4"), 2, "simulation.dimension", "must be 2 or 3"},
      {"bad_position", edit("[0.0, 0.05], [0.03, 0.05]", "[0.0, 0.05], [0.03]"), 20, "particles[0].positions[1]",
       "expected 2 numbers"},
      {"bad_damping", edit("kn = 1e5", "kn = 1e5\ndamping_ratio = 1.5"), 7, "contact.damping_ratio", "[0, 1)"},
      // (0.9999999 was refused as "must be in [0, 0.999999], got 1".)
      {"local_damping_one", std::string(kBase) + "[effects]\nlocal_damping = 1.0\n", 22, "effects.local_damping",
       "must be in [0, 1), got 1"},
      {"bad_criterion", std::string(kBase) + "[effects.breakage]\ncriterion = \"rankine\"\n", 22,
       "effects.breakage.criterion", "must be \"von_mises\""},
      {"negative_regrid_cells", std::string(kBase) + "[effects.breakage]\nregrid_cells = -2.0\n", 22,
       "effects.breakage.regrid_cells", "must be in [0, 1000]"},
      {"big_surface_shift", std::string(kBase) + "[effects.breakage]\nmax_surface_shift = 1.5\n", 22,
       "effects.breakage.max_surface_shift", "must be in [0, 1]"},
      {"small_imbalance", std::string(kBase) + "[parallel]\nrebalance_imbalance = 0.5\n", 22,
       "parallel.rebalance_imbalance", "must be >= 1 (or 0"},
      {"zero_rebalance_every", std::string(kBase) + "[parallel]\nrebalance_every = 0\n", 22,
       "parallel.rebalance_every", "must be >= 1 step"},
      {"unknown_balance", std::string(kBase) + "[parallel]\nbalance = \"atoms\"\n", 22, "parallel.balance",
       "unknown choice 'atoms' (nodes, time)"},
      {"unknown_parallel_key", std::string(kBase) + "[parallel]\nranks = 4\n", 22, "parallel.ranks", "unknown key"},
      {"text_surface_match", std::string(kBase) + "[effects.breakage]\nmatch_enclosed_volume = \"yes\"\n", 22,
       "effects.breakage.match_enclosed_volume", "expected true or false"},
      {"zero_regrid_factor", std::string(kBase) + "[effects.breakage]\nregrid_max_factor = 0\n", 22,
       "effects.breakage.regrid_max_factor", "must be in [1, 64]"},
      {"tiny_regrid_values", std::string(kBase) + "[effects.breakage]\nregrid_max_values = 8\n", 22,
       "effects.breakage.regrid_max_values", "must be in [64, 2^27]"},
      {"zero_fragment_nodes", std::string(kBase) + "[effects.breakage]\nmin_fragment_nodes = 0\n", 22,
       "effects.breakage.min_fragment_nodes", "must be in [1, 1e5]"},
      {"bad_regrid_nodes", std::string(kBase) + "[effects.breakage]\nregrid_nodes = \"dense\"\n", 22,
       "effects.breakage.regrid_nodes", "must be \"parent_spacing\" or \"per_new_cell\""},
      {"text_relax_new_contacts", std::string(kBase) + "[effects.breakage]\nrelax_new_contacts = 1\n", 22,
       "effects.breakage.relax_new_contacts", "expected true or false"},
      {"negative_min_volume", std::string(kBase) + "[effects.breakage]\nmin_volume = -1e-9\n", 22,
       "effects.breakage.min_volume", "must be >= 0"},
      // Chipping (docs/scenes.md, [effects.breakage.chipping]).
      {"bad_chip_depth_mode", std::string(kBase) + "[effects.breakage]\n[effects.breakage.chipping]\ndepth = \"deep\"\n",
       23, "effects.breakage.chipping.depth", "must be \"fraction\" or \"hertz\""},
      {"chip_fraction_one", std::string(kBase) + "[effects.breakage.chipping]\ndepth_fraction = 1.0\n", 22,
       "effects.breakage.chipping.depth_fraction", "must be in (0, 1)"},
      {"chip_negative_strength", std::string(kBase) + "[effects.breakage.chipping]\nreference_strength = -1.0\n", 22,
       "effects.breakage.chipping.reference_strength", "must be positive"},
      {"chip_hertz_without_e", std::string(kBase) + "[effects.breakage.chipping]\ndepth = \"hertz\"\n", 21,
       "effects.breakage.chipping", "missing key 'youngs_modulus'"},
      {"chip_hertz_factor_with_fraction", std::string(kBase) + "[effects.breakage.chipping]\nhertz_factor = 2.0\n", 22,
       "effects.breakage.chipping.hertz_factor", "no meaning with depth = \"fraction\""},
      {"chip_min_depth_cells", std::string(kBase) + "[effects.breakage.chipping]\nmin_depth_cells = 0.1\n", 22,
       "effects.breakage.chipping.min_depth_cells", "must be in [0.5, 1000]"},
      {"chip_unknown_key", std::string(kBase) + "[effects.breakage.chipping]\nstrength = 1e6\n", 22,
       "effects.breakage.chipping.strength", "unknown key"},
      {"chip_not_a_table", std::string(kBase) + "[effects.breakage]\nchipping = true\n", 22,
       "effects.breakage.chipping", "expected a table"},
      {"jaw_of_another_size", std::string(kBase) + "[[tools]]\nshape = \"disc\"\n[tools.motion]\ntype = \"jaw_crusher\"\n",
       23, "tools[0].motion.jaw_length", "is 1 m, but the tool's shape is 0.02 m long (its longest axis)"},
      {"negative_break_time",
       std::string(kBase) + "[effects.breakage]\n[[effects.breakage.manual]]\nparticle = 0\ntime = -1.0\npoint = [0.0, 0.0]\n", 24,
       "effects.breakage.manual[0].time", "must be >= 0 s, got -1"},
      {"negative_min_volume", std::string(kBase) + "[effects.breakage]\nmin_volume = -1e-9\n", 22,
       "effects.breakage.min_volume", "must be >= 0, got -1e-09"},
      {"chip_deeper_than_its_cap",
       std::string(kBase) + "[effects.breakage.chipping]\ndepth_fraction = 0.5\nmax_depth_fraction = 0.3\n", 22,
       "effects.breakage.chipping.depth_fraction", "is above max_depth_fraction = 0.3"},
      {"chip_modulus_with_fraction", std::string(kBase) + "[effects.breakage.chipping]\nyoungs_modulus = 1e9\n", 22,
       "effects.breakage.chipping.youngs_modulus", "has no meaning with depth = \"fraction\""},
      {"tiny_weibull_modulus", std::string(kBase) + "[effects.breakage]\nweibull_modulus = 0.001\n", 22,
       "effects.breakage.weibull_modulus", "must be in [0.5, 100], got 0.001"},
      {"negative_min_breakable_volume", std::string(kBase) + "[effects.breakage]\nmin_breakable_volume = -1e-9\n", 22,
       "effects.breakage.min_breakable_volume", "must be >= 0"},
      {"bad_motion", std::string(kBase) + "[[tools]]\nshape = \"disc\"\n[tools.motion]\ntype = \"wobble\"\n", 24,
       "tools[0].motion.type", "unknown motion 'wobble'"},
      {"zero_normal", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nnormal = [0.0, 0.0]\n", 23,
       "planes[0].normal", "zero vector"},
      {"syntax", edit("kn = 1e5", "kn = = 1e5"), 6, "", "TOML syntax error"},
      {"negative_shape_min_cells", std::string(kBase) + "[output]\nshape_min_cells = -1.0\n", 22,
       "output.shape_min_cells", "must be >= 0"},
      {"discharge_alone", std::string(kBase) + "[effects]\ndischarge = { min = [0.0, 0.0], max = [1.0, 1.0] }\n", 22,
       "effects.discharge", "needs an outflow box"},
      // Contact materials of walls and tools.
      {"wall_without_kn", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { ks = 1.0 }\n", 23,
       "planes[0].material", "missing key 'kn'"},
      {"hertz_wall_without_nu",
       edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9") +
           "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { youngs_modulus = 2e9 }\n",
       24, "planes[0].material", "missing key 'poisson_ratio'"},
      {"hertz_wall_bad_nu",
       edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9") +
           "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { youngs_modulus = 2e9, poisson_ratio = 0.7 }\n",
       24, "planes[0].material.poisson_ratio", "must be in [0, 0.499]"},
      {"tool_without_kn", std::string(kBase) + "[[tools]]\nshape = \"disc\"\nmaterial = { ks = 1.0 }\n", 23,
       "tools[0].material", "missing key 'kn'"},
      {"wall_friction_without_law_friction",
       std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { rigid = true, friction = 0.3 }\n", 23,
       "planes[0].material.friction", "needs `friction` in [contact]"},
      {"negative_wall_friction",
       edit("kn = 1e5", "kn = 1e5\nfriction = 0.3") +
           "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { kn = 1e6, friction = -0.1 }\n",
       24, "planes[0].material.friction", "must be >= 0"},
      {"rigid_wall_with_kn", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { rigid = true, kn = 1e6 }\n",
       23, "planes[0].material.kn", "no meaning for a rigid wall"},
      {"linear_wall_with_e", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { youngs_modulus = 1e9 }\n",
       23, "planes[0].material.youngs_modulus", "not read by the linear model"},
      {"negative_wall_kn", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { kn = -1.0 }\n", 23,
       "planes[0].material.kn", "must be positive"},
      {"unknown_wall_key", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { kn = 1.0, stiff = 2 }\n",
       23, "planes[0].material.stiff", "unknown key"},
      // The tangential model.
      {"bad_tangential", edit("kn = 1e5", "kn = 1e5\ntangential = \"coulomb\""), 7, "contact.tangential",
       "must be \"linear\" or \"mindlin\""},
      {"mindlin_without_hertz", edit("kn = 1e5", "kn = 1e5\ntangential = \"mindlin\""), 7, "contact.tangential",
       "needs model = \"hertz\""},
      {"mindlin_with_ks",
       edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9\nks = 5.0\ntangential = \"mindlin\""), 8,
       "contact.ks", "no meaning with tangential = \"mindlin\""},
      // Density scaling.
      {"negative_scaling_size", edit("steps = 10", "steps = 10\ndensity_scaling_below = -0.001"), 4,
       "simulation.density_scaling_below", "must be positive"},
      {"scaling_factor_below_one",
       edit("steps = 10", "steps = 10\ndensity_scaling_below = 0.001\ndensity_scaling_max = 0.5"), 5,
       "simulation.density_scaling_max", "must be >= 1"},
      // Keys a model does not read, and what one cannot do without.
      {"hertz_with_kn", edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9\nkn = 1e5"), 8, "contact.kn",
       "has no meaning under model = \"hertz\""},
      {"hertz_linear_spring_without_ks",
       edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9\nfriction = 0.4\ntangential = \"linear\""), 9,
       "contact.tangential", "\"linear\" under model = \"hertz\" needs `ks`"},
      {"motion_without_type", std::string(kBase) + "[[tools]]\nshape = \"disc\"\n[tools.motion]\nrpm = 3.0\n", 23,
       "tools[0].motion", "missing key 'type'"},
      {"specimen_top_is_bottom",
       std::string(kBase) + "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\n[output.specimen]\ntop = \"floor\"\n"
                            "bottom = \"floor\"\nwidth = 0.1\n",
       26, "output.specimen.bottom", "is the top too"},
      {"specimen_area_in_2d",
       std::string(kBase) + "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\n[output.specimen]\ntop = \"floor\"\n"
                            "bottom = \"floor\"\narea = 0.1\n",
       27, "output.specimen.area", "is the 3D key: a 2D specimen takes `width` (m)"},
      {"cloud_without_count",
       edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
            "placement = \"cloud\"\nregion = { min = [0.0, 0.0], max = [1.0, 1.0] }"),
       16, "particles[0]", "missing key 'count'"},
      {"specimen_on_a_tool",
       std::string(kBase) + "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\n[[tools]]\nname = \"ram\"\nshape = \"disc\"\n"
                            "[output.specimen]\ntop = \"floor\"\nbottom = \"ram\"\nwidth = 0.1\n",
       29, "output.specimen.bottom", "no plane named 'ram' (a tool cannot be the bottom)"},
      {"scaling_factor_alone", edit("steps = 10", "steps = 10\ndensity_scaling_max = 5.0"), 4,
       "simulation.density_scaling_max", "needs `density_scaling_below`"},
      // Tracked particles.
      {"track_fraction", std::string(kBase) + "[output]\ntrack = [0, 1.5]\n", 22, "output.track",
       "whole numbers >= 0"},
      {"track_negative", std::string(kBase) + "[output]\ntrack = [-1]\n", 22, "output.track", "whole numbers >= 0"},
      {"track_twice", std::string(kBase) + "[output]\ntrack = [1, 0, 1]\n", 22, "output.track", "listed twice"},
      {"frame_pieces", std::string(kBase) + "[output]\nframe_pieces = \"rank\"\n", 22, "output.frame_pieces",
       "unknown choice 'rank' (gathered, ranks)"},
      {"track_every_alone", std::string(kBase) + "[output]\ntrack_every = 0.1\n", 22, "output.track_every",
       "needs `track`"},
      {"track_every_negative", std::string(kBase) + "[output]\ntrack = [0]\ntrack_every = -1.0\n", 23,
       "output.track_every", "must be >= 0"},
  };
  for (const BadCase& c : cases) {
    const fs::path file = writeScene(c.name, c.scene);
    try {
      io::readScene(file.string());
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.file(), file.string()) << c.name;
      EXPECT_EQ(e.line(), c.line) << c.name << ": " << e.what();
      EXPECT_EQ(e.key(), c.key) << c.name << ": " << e.what();
      EXPECT_NE(e.problem().find(c.message), std::string::npos) << c.name << ": " << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << c.name;
    }
  }
}

// A value out of range is quoted as it was written (the docs' example):
// the shortest text of the number, not six decimals.
TEST(Scene, AValueOutOfRangeIsQuotedAsWritten) {
  try {
    io::readScene(writeScene("friction_digits", edit("kn = 1e5", "kn = 1e5\nfriction = -0.2")).string());
    FAIL() << "a negative friction was accepted";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.key(), "contact.friction");
    EXPECT_EQ(e.problem(), "must be >= 0, got -0.2");
  }
}

// Walls and tools with their own contact material, Hertz with friction and
// no ks (Mindlin's spring), and density scaling.
TEST(Scene, WallMaterialsMindlinAndDensityScaling) {
  const std::string scene = edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9\nfriction = 0.4") +
                            "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { rigid = true, friction = 0.2 }\n"
                            "[[planes]]\npoint = [0.1, 0.0]\nnormal = [-1.0, 0.0]\n"
                            "[[tools]]\nshape = \"disc\"\nposition = [0.5, 0.5]\n"
                            "[tools.material]\nyoungs_modulus = 2e11\npoisson_ratio = 0.3\n";
  const auto any = io::readScene(writeScene("materials", scene).string());
  const auto& s = as<2>(any);
  EXPECT_EQ(s.world.contact.tangential, dynamics::TangentialModel::Mindlin);
  ASSERT_EQ(s.planes.size(), 2u);
  ASSERT_TRUE(s.planes[0].material);
  EXPECT_TRUE(s.planes[0].material->rigid);
  EXPECT_EQ(s.planes[0].material->friction, 0.2);
  EXPECT_FALSE(s.planes[1].material);  // the grains' material
  ASSERT_TRUE(s.tools[0].material);
  EXPECT_EQ(s.tools[0].material->youngsModulus, 2e11);
  EXPECT_EQ(s.tools[0].material->poissonRatio, 0.3);
  EXPECT_FALSE(s.world.densityScaling);  // not asked for
  // With ks the Hertz law keeps the linear spring; density scaling read.
  const auto linear = io::readScene(
      writeScene("hertz_ks", edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 1e9\nfriction = 0.4\nks = 50.0"))
          .string());
  EXPECT_EQ(as<2>(linear).world.contact.tangential, dynamics::TangentialModel::Linear);
  const auto scaled = io::readScene(writeScene(
      "scaled", edit("steps = 10", "steps = 10\ndensity_scaling_below = 0.004\ndensity_scaling_max = 20")).string());
  ASSERT_TRUE(as<2>(scaled).world.densityScaling);
  EXPECT_EQ(as<2>(scaled).world.densityScaling->belowDiameter, 0.004);
  EXPECT_EQ(as<2>(scaled).world.densityScaling->maxFactor, 20.0);
}

// Values the physics cannot survive, names that would break a CSV header, and
// contradictory keys: refused with file, line and key (issue 16).
TEST(Scene, UnsurvivableValuesNamesAndConflictsAreRefused) {
  const std::string tool = "[[tools]]\nshape = \"disc\"\nposition = [0.1, 0.3]\n[tools.motion]\ntype = \"key_frames\"\n"
                           "[[tools.motion.frames]]\ntime = 0.0\nposition = [0.2, 0.3]\n";
  const std::vector<BadCase> cases = {
      {"comma_name", std::string(kBase) + "[[planes]]\nname = \"fl,oor\"\npoint = [0.0, 0.0]\n", 22, "planes[0].name",
       "commas"},
      {"nul_name", std::string(kBase) + "[[planes]]\nname = \"fl\\u0000oor\"\npoint = [0.0, 0.0]\n", 22,
       "planes[0].name", "control characters"},
      {"newline_tool_name", std::string(kBase) + "[[tools]]\nname = \"a\\nb\"\nshape = \"disc\"\n", 22, "tools[0].name",
       "control characters"},
      {"quote_material", edit("[materials.rock]\ndensity = 2000.0", "[materials.'ro\"ck']\ndensity = 2000.0"), 8,
       "materials.ro\"ck", "double quotes"},
      {"key_frames_position", std::string(kBase) + tool, 23, "tools[0].position", "first key frame"},
      {"key_frames_angle",
       std::string(kBase) + "[[tools]]\nshape = \"disc\"\nangle_deg = 30.0\n[tools.motion]\ntype = \"key_frames\"\n"
                            "[[tools.motion.frames]]\ntime = 0.0\nposition = [0.2, 0.3]\n",
       23, "tools[0].angle_deg", "first key frame"},
      {"spacing_above_grain", edit("cells_across = 16", "spacing = 1.0"), 14, "shapes.disc.spacing", "cells across"},
      {"spacing_far_below_grain", edit("cells_across = 16", "spacing = 1e-9"), 14, "shapes.disc.spacing",
       "cells across"},
      {"grid_beyond_limit",
       edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
            "placement = \"grid\"\nregion = { min = [0.0, 0.0], max = [1e3, 1e3] }"),
       16, "particles", "over the limit of 1e7"},
      // What the world refuses while the particles are added is an input
      // error at the key that causes it (exit 1 before; a Hertz modulus of
      // 1e308 whose stiffness overflows is fuzz/regressions/fuzz_scene/).
      {"dt_above_critical", edit("steps = 10\n", "steps = 10\ndt = 1.0\n"), 4, "simulation.dt",
       "exceeds the critical time step"},
      // Listed positions that cannot be meant: two grains at one place (one
      // holds the other's centroid; overlapping short of that is fine:
      // next_to below), a grain behind a plane.
      {"same_place", edit("[[0.0, 0.05], [0.03, 0.05]]", "[[0.0, 0.05], [0.005, 0.05]]"), 16, "particles",
       "positions[1] = (0.005, 0.05) overlaps particle 0"},
      {"behind_plane",
       std::string(kBase) + "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.055]\nnormal = [0.0, 1.0]\n", 16,
       "particles", "positions[0] = (0, 0.05) lies behind plane 'floor'"},
      // So are a grid and a feed behind a plane (a cloud draws again).
      {"grid_behind_plane",
       edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
            "placement = \"grid\"\nregion = { min = [0.0, -0.1], max = [0.06, -0.03] }") +
           "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n",
       16, "particles", "the grid's particle 0 at (0.01"},
      {"inside_a_tool",
       std::string(kBase) + "[[tools]]\nname = \"ram\"\nshape = \"disc\"\nposition = [0.031, 0.05]\n", 16, "particles",
       "positions[1] = (0.03, 0.05) lies inside tool 'ram'"},
      {"feed_interval_and_clearance",
       edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
            "placement = \"feed\"\npoint = [0.0, 0.05]\ninterval = 0.001\nclearance = 0.02"),
       22, "particles[0].clearance", "has no meaning with an interval"},
      {"feed_behind_plane",
       edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
            "placement = \"feed\"\npoint = [0.0, -0.01]\ninterval = 0.001") +
           "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n",
       16, "particles", "the feed point (0, -0.01) lies behind plane 'floor'"},
  };
  for (const BadCase& c : cases) {
    const fs::path file = writeScene(c.name, c.scene);
    try {
      const io::AnySceneDef scene = io::readScene(file.string());
      io::buildWorld(as<2>(scene));  // placement limits and the time step are found while placing
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.line(), c.line) << c.name << ": " << e.what();
      EXPECT_EQ(e.key(), c.key) << c.name << ": " << e.what();
      EXPECT_NE(e.problem().find(c.message), std::string::npos) << c.name << ": " << e.what();
    }
  }
  // Grains that overlap without holding each other's centroid, and a grain
  // across a plane with its centroid in front of it, are placed as listed.
  EXPECT_NO_THROW(io::buildWorld(as<2>(io::readScene(
      writeScene("next_to", edit("[[0.0, 0.05], [0.03, 0.05]]",
                                 "[[0.0, 0.05], [0.015, 0.05]]") +
                                "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.045]\nnormal = [0.0, 1.0]\n")
          .string()))));
  // A cloud whose region reaches behind a plane places its grains in front of it.
  {
    const auto built = io::buildWorld(as<2>(io::readScene(
        writeScene("cloud_across_plane",
                   edit("placement = \"list\"\npositions = [[0.0, 0.05], [0.03, 0.05]]",
                        "placement = \"cloud\"\ncount = 6\nregion = { min = [0.0, -0.1], max = [0.1, 0.1] }") +
                       "[[planes]]\nname = \"floor\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n")
            .string())));
    ASSERT_EQ(built.world->particles().size(), 6u);
    for (const auto& x : built.world->particles().position) EXPECT_GE(x[1], 0.0);
  }
  // A key_frames tool whose own pose is its first frame's is accepted (the demolition scene).
  std::string agreeing = std::string(kBase) + tool;
  agreeing.replace(agreeing.find("position = [0.1, 0.3]"), 21, "position = [0.2, 0.3]");
  EXPECT_NO_THROW(io::readScene(writeScene("key_frames_agree", agreeing).string()));
}

// A direction given with components near the double range keeps its true
// direction (its plain norm overflows to infinity).
TEST(Scene, DirectionsNearTheDoubleRangeNormaliseExactly) {
  const io::AnySceneDef any = io::readScene(
      writeScene("huge_normal", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nnormal = [1e308, -1e308]\n")
          .string());
  const auto& n = as<2>(any).planes.at(0).plane.normal;
  EXPECT_NEAR(n.x(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(n.y(), -std::sqrt(0.5), 1e-15);
  const io::AnySceneDef tiny = io::readScene(
      writeScene("tiny_normal", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nnormal = [0.0, 5e-324]\n")
          .string());
  EXPECT_EQ(as<2>(tiny).planes.at(0).plane.normal.y(), 1.0);
}

TEST(Scene, LsdemRunExitsWithCodeTwoAndOneLine) {
  const fs::path file = writeScene("cli_bad", edit("kn = 1e5", "kn = -3"));
  const std::string cmd = std::string(LSDEM_BINARY) + " run " + file.string() + " --out " +
                          (file.parent_path() / "cli_out").string() + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buf[512];
  while (fgets(buf, sizeof(buf), pipe)) out += buf;
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_EQ(out, "lsdem: " + file.string() + ":6: contact.kn: must be positive, got -3\n");

  // A wall's material missing its stiffness: the same, and nothing written.
  const fs::path wall =
      writeScene("cli_bad_wall", std::string(kBase) + "[[planes]]\npoint = [0.0, 0.0]\nmaterial = { friction = 0.1 }\n");
  const fs::path outDir = file.parent_path() / "cli_out_wall";
  fs::remove_all(outDir);
  pipe = popen((std::string(LSDEM_BINARY) + " run " + wall.string() + " --out " + outDir.string() + " 2>&1").c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  out.clear();
  while (fgets(buf, sizeof(buf), pipe)) out += buf;
  EXPECT_EQ(WEXITSTATUS(pclose(pipe)), 2);
  EXPECT_EQ(out, "lsdem: " + wall.string() + ":23: planes[0].material: missing key 'kn'\n");
  EXPECT_FALSE(fs::exists(outDir));
}

TEST(Scene, CloudAndGridPlacementsAreDeterministicAndDoNotOverlap) {
  const std::string scene = std::string(kBase) + R"(
[[particles]]
shape = "disc"
density = 2500.0
placement = "cloud"
region = { min = [0.0, 0.1], max = [0.2, 0.3] }
count = 40
random_orientation = true
diameter_range = [0.01, 0.02]

[[particles]]
shape = "disc"
density = 2500.0
placement = "grid"
region = { min = [0.0, 0.4], max = [0.1, 0.45] }
)";
  const fs::path file = writeScene("placement", scene);
  const auto any = io::readScene(file.string());
  const io::SceneWorld<2> a = io::buildWorld(as<2>(any));
  const io::SceneWorld<2> b = io::buildWorld(as<2>(io::readScene(file.string())));
  const auto& p = a.world->particles();
  // 2 listed, 40 in the cloud, the grid: floor(0.1 / (0.02 x 1.0001)) x floor(0.05 / ...) = 4 x 2.
  ASSERT_EQ(p.size(), 2u + 40u + 8u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.position[i], b.world->particles().position[i]);
    // Discs do not overlap: centres at least the sum of their radii apart
    // (the placement tests the shapes, with half a cell of clearance).
    for (std::size_t j = 0; j < i; ++j) {
      EXPECT_GE((p.position[i] - p.position[j]).norm(),
                0.5 * (p.shape[i]->descriptors().equivalentDiameter + p.shape[j]->descriptors().equivalentDiameter));
    }
  }
  // Sizes in the cloud: equivalent diameters inside the range, shapes scaled exactly.
  for (std::size_t i = 2; i < 42; ++i) {
    const double d = p.shape[i]->descriptors().equivalentDiameter;
    EXPECT_GE(d, 0.01 * (1 - 1e-12));
    EXPECT_LE(d, 0.02 * (1 + 1e-12));
    EXPECT_NEAR(p.shape[i]->volume(), std::acos(-1.0) * d * d / 4.0, 1e-12);
    EXPECT_GE(p.position[i].y() - 0.5 * p.shape[i]->descriptors().equivalentDiameter, 0.1 - 1e-9);
  }
}

TEST(Scene, ToolsArePlacedByTheirShapeFrameAndEffectsOnlyWhenDeclared) {
  const std::string scene = std::string(kBase) + R"(
[shapes.plate]
kind = "rectangle"
half_extents = [0.05, 0.01]
cells_across = 8

[[tools]]
name = "press"
shape = "plate"
position = [0.1, 0.2]
angle_deg = 90.0

[[particles]]
shape = "disc"
density = 2500.0
placement = "feed"
point = [0.0, 0.5]
interval = 0.01
count = 3

[effects]
gravity = [0.0, -9.81]
local_damping = 0.2
outflow = { min = [-1.0, -1.0], max = [1.0, 1.0] }

[effects.breakage]
criterion = "tresca"
)";
  const io::SceneWorld<2> w = io::buildWorld(as<2>(io::readScene(writeScene("tools", scene).string())));
  ASSERT_EQ(w.world->tools().size(), 1u);
  // A centred, symmetric rectangle: its centroid is its build origin.
  EXPECT_NEAR((w.world->toolPoses()[0].position - geometry::Vec<2>(0.1, 0.2)).norm(), 0.0, 1e-6);
  EXPECT_EQ(w.world->effectNames(),
            (std::vector<std::string>{"gravity", "local_damping", "breakage", "outflow", "feed"}));
  ASSERT_NE(w.breakage, nullptr);
  EXPECT_EQ(w.breakage->criterion().name(), "tresca");
  ASSERT_EQ(w.feeds.size(), 1u);
}

// Chipping is declared by its table; its keys reach the effect, and the
// Hertz depth takes the contact law's E and nu when the law is Hertz.
TEST(Scene, ChippingOnlyWhenDeclared) {
  const auto def = [](const std::string& text) {
    return as<2>(io::readScene(writeScene("chipping", text).string())).breakage;
  };
  const auto off = def(std::string(kBase) + "[effects.breakage]\n");
  ASSERT_TRUE(off.has_value());
  EXPECT_FALSE(off->chipping.has_value());
  const auto on = def(std::string(kBase) +
                      "[effects.breakage.chipping]\nreference_strength = 3e7\nreference_depth = 2e-4\n"
                      "weibull_modulus = 5.0\ndepth_fraction = 0.15\nmax_depth_fraction = 0.2\nmin_depth_cells = 2.0\n");
  ASSERT_TRUE(on && on->chipping);
  EXPECT_EQ(on->chipping->weibull.referenceStrength, 3e7);
  EXPECT_EQ(on->chipping->weibull.referenceDiameter, 2e-4);
  EXPECT_EQ(on->chipping->weibull.modulus, 5.0);
  EXPECT_EQ(on->chipping->depth, breakage::ChipDepthMode::Fraction);
  EXPECT_EQ(on->chipping->depthFraction, 0.15);
  EXPECT_EQ(on->chipping->maxDepthFraction, 0.2);
  EXPECT_EQ(on->chipping->minDepthCells, 2.0);
  const auto hertz = def(edit("kn = 1e5", "model = \"hertz\"\nyoungs_modulus = 7e10\npoisson_ratio = 0.2") +
                         "[effects.breakage.chipping]\ndepth = \"hertz\"\nhertz_factor = 1.5\n");
  ASSERT_TRUE(hertz && hertz->chipping);
  EXPECT_EQ(hertz->chipping->depth, breakage::ChipDepthMode::Hertz);
  EXPECT_EQ(hertz->chipping->hertzFactor, 1.5);
  EXPECT_EQ(hertz->chipping->youngsModulus, 7e10);
  EXPECT_EQ(hertz->chipping->poissonRatio, 0.2);
}

TEST(Scene, ScaledShapesScaleExactly) {
  const auto any = io::readScene(writeScene("scale", kBase).string());
  const auto& shape = *as<2>(any).shapes[0];
  const auto big = io::scaledShape(shape, 2.5);
  EXPECT_NEAR(big->volume(), shape.volume() * 6.25, 1e-15);
  EXPECT_NEAR(big->boundingRadius(), shape.boundingRadius() * 2.5, 1e-15);
  EXPECT_NEAR(big->descriptors().circularity, shape.descriptors().circularity, 1e-15);
  EXPECT_NEAR(big->mass().secondMoment(0, 0), shape.mass().secondMoment(0, 0) * std::pow(2.5, 4), 1e-18);
  // The level set at a scaled point is the scaled level set.
  const geometry::Vec<2> x(0.004, -0.003);
  EXPECT_NEAR(big->value(2.5 * x), 2.5 * shape.value(x), 1e-7);
  EXPECT_THROW(io::scaledShape(shape, 0.0), std::invalid_argument);
}

TEST(Scene, AFolderOfGrainFilesIsAShapePool) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_scene") / "pool";
  fs::create_directories(dir);
  const auto any = io::readScene(writeScene("pool_base", kBase).string());
  const auto& disc = *as<2>(any).shapes[0];
  io::writeGrainFile<2>((dir / "a.lsg").string(), disc, io::GrainFormat::Binary);
  io::writeGrainFile<2>((dir / "b.lsg").string(), *io::scaledShape(disc, 0.5), io::GrainFormat::Text);
  const std::string scene = edit("kind = \"circle\"\nradius = 0.01\ncells_across = 16",
                                 "kind = \"grain_folder\"\npath = \"pool\"");
  const io::SceneWorld<2> w = io::buildWorld(as<2>(io::readScene(writeScene("pool", scene).string())));
  ASSERT_EQ(w.world->particles().size(), 2u);
  // Cycled in file-name order: the full disc, then the half-size one.
  EXPECT_EQ(w.world->particles().shape[0]->volume(), disc.volume());
  EXPECT_NEAR(w.world->particles().shape[1]->volume(), 0.25 * disc.volume(), 1e-18);
  // A missing folder or file: at the shape's path key (the grain file's own
  // message named no scene line).
  fs::create_directories(dir.parent_path() / "empty_pool");
  for (const auto& [kind, path] : {std::pair{"grain_folder", "no_pool"}, std::pair{"grain_folder", "empty_pool"},
                                   std::pair{"grain_file", "pool/none.lsg"}, std::pair{"grain_file", "pool"}}) {
    const std::string missing = edit("kind = \"circle\"\nradius = 0.01\ncells_across = 16",
                                     std::string("kind = \"") + kind + "\"\npath = \"" + path + "\"");
    try {
      io::readScene(writeScene("missing_pool", missing).string());
      ADD_FAILURE() << kind;
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.key(), "shapes.disc.path") << e.what();
      EXPECT_NE(e.problem().find(path), std::string::npos) << e.what();
    }
  }
}

TEST(Scene, ListOrientationsTurnThePrincipalFrame3D) {
  const std::string scene = R"([simulation]
dimension = 3
steps = 1
[contact]
kn = 1e5
[shapes.egg]
kind = "ellipsoid"
semi_axes = [0.03, 0.02, 0.01]
cells_across = 8
[[particles]]
shape = "egg"
density = 1000.0
positions = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]
rotations_deg = [[0.0, 0.0, 90.0], [90.0, 0.0, 0.0]]
)";
  const io::SceneWorld<3> w = io::buildWorld(as<3>(io::readScene(writeScene("rot3", scene).string())));
  const auto& p = w.world->particles();
  // The longest axis (body x) turned about z onto world y; the middle (body y) turned about x onto world z.
  EXPECT_NEAR((p.rotation(0) * geometry::Vec<3>::UnitX() - geometry::Vec<3>::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((p.rotation(1) * geometry::Vec<3>::UnitY() - geometry::Vec<3>::UnitZ()).norm(), 0.0, 1e-12);
  // One rotation per position.
  std::string bad = scene;
  bad.replace(bad.find(", [90.0, 0.0, 0.0]"), 18, "");
  EXPECT_THROW(io::readScene(writeScene("rot3_bad", bad).string()), io::InputError);
}

TEST(Scene, AFeedAloneStartsWithAnAutomaticStepAndWaitsForAFreePoint) {
  const std::string feedOnly = R"([simulation]
dimension = 2
steps = 3000
[contact]
kn = 1e5
damping_ratio = 0.3
[shapes.disc]
kind = "circle"
radius = 0.01
cells_across = 12
[[particles]]
shape = "disc"
density = 2000.0
placement = "feed"
point = [0.0, 0.05]
interval = 0.001
[[planes]]
point = [0.0, 0.0]
normal = [0.0, 1.0]
[effects]
gravity = [0.0, -9.81]
)";
  io::SceneWorld<2> w = io::buildWorld(as<2>(io::readScene(writeScene("feed_only", feedOnly).string())));
  ASSERT_GT(w.world->dt(), 0.0);  // from the feed's grains
  EXPECT_EQ(w.world->particles().size(), 0u);
  // Every 1 ms a grain is due, but the point is free only once the last one has
  // fallen a diameter: far fewer drops than intervals, and never an overlap at birth.
  std::size_t seen = 0;
  for (int s = 0; s < 3000; ++s) {
    w.world->step();
    const auto& p = w.world->particles();
    for (; seen < p.size(); ++seen) {
      for (std::size_t j = 0; j < seen; ++j) EXPECT_GE((p.position[seen] - p.position[j]).norm(), 0.02 - 1e-12);
    }
  }
  const double intervals = w.world->time() / 0.001;
  EXPECT_GE(w.feeds[0]->dropped(), 2u);
  EXPECT_LT(double(w.feeds[0]->dropped()), 0.8 * intervals);
}

// An input error is one line whatever the parser echoes from the file (found
// by fuzz_scene: a TOML syntax error quoting "tr\n"; the input is in
// fuzz/regressions/fuzz_scene/).
TEST(Scene, InputErrorsAreOneLine) {
  const io::InputError e("scene.toml", 3, "shapes.a\nb", std::string("saw 'tr\n', then \0 and \t", 23));
  EXPECT_STREQ(e.what(), "scene.toml:3: shapes.a\\nb: saw 'tr\\n', then \\x00 and \\t");
  EXPECT_EQ(e.problem(), "saw 'tr\\n', then \\x00 and \\t");
  std::string text = kBase;
  text += "[effects]\ngravity = tr\n";
  try {
    io::readScene(writeScene("newline_error", text).string());
    ADD_FAILURE() << "accepted";
  } catch (const io::InputError& err) {
    EXPECT_EQ(std::string(err.what()).find('\n'), std::string::npos) << err.what();
  }
}

// A jaw_crusher plate is checked against the motion's jaw_length and
// jaw_thickness along its own axes, by its level set: a 3D plate (length,
// width, thickness) is read, and its motion takes the thickness for the face
// normal (plateFrame3D); a 2D rounded plate with sparse nodes is read (its
// nodes gave 0.964 m for a 1 m plate); a plate thicker than jaw_thickness is
// refused at that key.
TEST(Scene, AJawPlateIsCheckedAlongItsOwnAxes) {
  const std::string plate3 = R"([simulation]
dimension = 3
steps = 10

[contact]
kn = 1e5

[shapes.plate]
kind = "box"
half_extents = [0.5, 0.3, 0.05]
cells_across = 6

[[particles]]
shape = "plate"
density = 1000.0
placement = "list"
positions = [[5.0, 5.0, 5.0]]

[[tools]]
shape = "plate"
[tools.motion]
type = "jaw_crusher"
)";
  const auto s3 = as<3>(io::readScene(writeScene("jaw3", plate3).string()));
  const auto& jaw3 = std::get<dynamics::JawCrusher<3>>(s3.tools.at(0).motion);
  EXPECT_TRUE(jaw3.plateFrame.isApprox(dynamics::plateFrame3D()));
  // A 3D plate's thickness is its shortest axis, not its width; one wider
  // than long is refused (it would stand turned in its own plane).
  const auto edit3 = [](std::string text, const std::string& from, const std::string& to) {
    return text.replace(text.find(from), from.size(), to);
  };
  for (const auto& [text, key, message] :
       {std::tuple{plate3 + "jaw_thickness = 0.6\n", "tools[0].motion.jaw_thickness",
                   "is 0.6 m, but the tool's shape is 0.1 m thick"},
        std::tuple{edit3(plate3, "half_extents = [0.5, 0.3, 0.05]", "half_extents = [0.3, 0.5, 0.05]") +
                       "jaw_length = 0.6\n",
                   "tools[0].motion.jaw_length", "is the plate's width (0.6 m, its middle axis), not its length (1 m"}}) {
    try {
      io::readScene(writeScene("jaw3_bad", text).string());
      ADD_FAILURE() << text;
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.key(), key) << e.what();
      EXPECT_NE(e.problem().find(message), std::string::npos) << e.what();
    }
  }
  const std::string plate2 = R"([simulation]
dimension = 2
steps = 10

[contact]
kn = 1e5

[shapes.plate]
kind = "box"
half_extents = [0.5, 0.05]
rounding = 0.045
cells_across = 10
node_density = 0.05

[[particles]]
shape = "plate"
density = 1000.0
placement = "list"
positions = [[5.0, 5.0]]

[[tools]]
shape = "plate"
[tools.motion]
type = "jaw_crusher"
)";
  EXPECT_NO_THROW(io::readScene(writeScene("jaw2", plate2).string()));
  try {
    io::readScene(writeScene("jaw_thick", std::string(plate2) + "jaw_thickness = 0.05\n").string());
    ADD_FAILURE() << "a 0.1 m plate was read with jaw_thickness = 0.05";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.key(), "tools[0].motion.jaw_thickness") << e.what();
    EXPECT_NE(e.problem().find("is 0.05 m, but the tool's shape is 0.1 m thick (its shortest axis)"), std::string::npos)
        << e.what();
  }
}
