// The pure parts of the breakage accuracy study (BreakageAccuracy.h): size
// quantiles and the L1 distance of cumulative curves against hand values, the
// fitted order of an exact power law, the scene text of a setting, and the
// summaries (reference, errors, seed noise, budgets) of synthetic runs.

#include "lsdem/io/Scene.h"
#include "lsdem/study/BreakageAccuracy.h"

#include "support/Files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <variant>

using namespace lsdem::study;

TEST(BreakageAccuracy, SizeQuantileInterpolatesInLogSize) {
  SizeDistribution psd{{1e-4, 1e-3, 1e-2}, {0.2, 0.6, 1.0}};
  EXPECT_DOUBLE_EQ(sizeQuantile(psd, 0.1), 1e-4);  // below the first point: the smallest size
  EXPECT_DOUBLE_EQ(sizeQuantile(psd, 0.2), 1e-4);
  EXPECT_NEAR(sizeQuantile(psd, 0.4), std::sqrt(1e-4 * 1e-3), 1e-15);  // halfway in log size
  EXPECT_NEAR(sizeQuantile(psd, 0.8), std::sqrt(1e-3 * 1e-2), 1e-14);
  EXPECT_DOUBLE_EQ(sizeQuantile(psd, 1.0), 1e-2);
  EXPECT_THROW(sizeQuantile(SizeDistribution{}, 0.5), std::invalid_argument);
  EXPECT_THROW(sizeQuantile(psd, 0.0), std::invalid_argument);
}

TEST(BreakageAccuracy, PsdDistanceIsTheAreaBetweenTheCurvesInDecades) {
  const SizeDistribution a{{1e-4, 1e-3, 1e-2}, {0.2, 0.6, 1.0}};
  EXPECT_DOUBLE_EQ(psdDistance(a, a), 0.0);
  // Every size times 2: |log10 2| whatever the shape of the curve.
  SizeDistribution b = a;
  for (double& s : b.size) s *= 2.0;
  EXPECT_NEAR(psdDistance(a, b), std::log10(2.0), 1e-12);
  EXPECT_NEAR(psdDistance(b, a), std::log10(2.0), 1e-12);
  // One step of 0.5 moved by one decade: 0.5 x 1.
  const SizeDistribution c{{1e-3, 1e-2}, {0.5, 1.0}}, d{{1e-3, 1e-1}, {0.5, 1.0}};
  EXPECT_NEAR(psdDistance(c, d), 0.5, 1e-12);
}

TEST(BreakageAccuracy, FitOrderRecoversAPowerLaw) {
  const std::vector<double> cells = {10, 20, 40, 80};
  std::vector<double> err;
  for (double c : cells) err.push_back(3.0 * std::pow(c, -1.5));
  const ConvergenceOrder o = fitOrder(cells, err);
  EXPECT_EQ(o.points, 4);
  EXPECT_NEAR(o.order, 1.5, 1e-12);
  // Zero errors are left out; one point gives no order.
  EXPECT_EQ(fitOrder({10, 20}, {0.1, 0.0}).points, 1);
  EXPECT_EQ(fitOrder({10, 20}, {0.1, 0.0}).order, 0.0);
}

TEST(BreakageAccuracy, SceneTextOfASettingIsAValidSceneWithTheStiffnessScaled) {
  ASSERT_EQ(breakageCases().size(), 3u);
  for (const BreakageCase& c : breakageCases()) {
    // The embedded text is the shipped scene's, and shippedCells is its grid.
    EXPECT_EQ(c.text, lsdem::test::readFile(std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/" + c.scene)) << c.name;
    EXPECT_NE(c.text.find("cells_across = " + std::to_string(int(c.shippedCells))), std::string::npos) << c.name;

    BreakageSetting s;
    s.cellsAcross = c.shippedCells / 2;
    s.nodeDensity = 2.0;
    s.regridCells = 20.0;
    const std::string text = breakageSceneText(c, s, 987);
    const auto path = lsdem::test::tempPath(c.name + ".toml");
    std::ofstream(path) << text;
    const lsdem::io::AnySceneDef any = lsdem::io::readScene(path.string());
    const auto& scene = std::get<lsdem::io::SceneDef<2>>(any);
    // Per node at 2 nodes per cell on half the cells: kn x 2 / 2.
    EXPECT_DOUBLE_EQ(scene.world.contact.kn, 1e5) << c.name;
    EXPECT_EQ(scene.threads, 1) << c.name;
    EXPECT_EQ(scene.output.frames, 0u) << c.name;
    EXPECT_EQ(scene.output.distributions, 2u) << c.name;
    EXPECT_DOUBLE_EQ(scene.output.shapeMinCells, c.shippedMinCells / 2) << c.name;
    EXPECT_NE(text.find("seed = 987"), std::string::npos) << c.name;
    EXPECT_NE(text.find("regrid_cells = 20"), std::string::npos) << c.name;

    s.formulation = lsdem::dynamics::ForceFormulation::AreaWeighted;
    std::ofstream(path) << breakageSceneText(c, s, 987);
    const lsdem::io::AnySceneDef anyAw = lsdem::io::readScene(path.string());
    const auto& aw = std::get<lsdem::io::SceneDef<2>>(anyAw);
    EXPECT_DOUBLE_EQ(aw.world.contact.kn, 2e5) << c.name;  // area-weighted: node density does not count
    EXPECT_EQ(aw.world.contact.formulation, lsdem::dynamics::ForceFormulation::AreaWeighted) << c.name;
  }
}

// The 3D case: the shipped single grain between platens, its contact
// stiffness per unit area held on every grid (kn x (20 / cells)^2, and
// / node_density^2 per node), its breakage sizes (fines below 5e-12 m^3,
// unbreakable below 5e-11 m^3) the same physical sizes at every grid.
TEST(BreakageAccuracy, TheThreeDimensionalCaseIsTheSingleGrainWithItsStiffnessPerAreaHeld) {
  ASSERT_EQ(breakageCases(3).size(), 1u);
  const BreakageCase& c = breakageCases(3).front();
  EXPECT_EQ(c.name, "single_grain_3d");
  EXPECT_EQ(c.dimension, 3);
  EXPECT_EQ(c.text, lsdem::test::readFile(std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/" + c.scene));
  EXPECT_NE(c.text.find("cells_across = 20"), std::string::npos);
  EXPECT_NE(c.text.find("kn = 3.2e3"), std::string::npos);
  EXPECT_THROW(breakageCases(4), std::invalid_argument);

  BreakageSetting s;
  s.cellsAcross = 10;
  s.nodeDensity = 2.0;
  const auto path = lsdem::test::tempPath("single_grain_3d.toml");
  std::ofstream(path) << breakageSceneText(c, s, 55);
  const lsdem::io::AnySceneDef any = lsdem::io::readScene(path.string());
  ASSERT_TRUE(std::holds_alternative<lsdem::io::SceneDef<3>>(any));
  const auto& scene = std::get<lsdem::io::SceneDef<3>>(any);
  // Per node: 3.2e3 x (20 / 10)^2 / 2^2.
  EXPECT_DOUBLE_EQ(scene.world.contact.kn, 3.2e3);
  EXPECT_EQ(scene.threads, 1);
  EXPECT_DOUBLE_EQ(scene.output.shapeMinCells, 2.5);
  ASSERT_EQ(scene.shapes.size(), 1u);
  ASSERT_EQ(scene.groups.size(), 1u);
  EXPECT_EQ(scene.groups[0].positions.size(), 1u);  // one grain
  ASSERT_TRUE(scene.breakage.has_value());
  EXPECT_EQ(scene.breakage->seed, 55u);
  EXPECT_DOUBLE_EQ(scene.breakage->minVolume, 5e-12);
  EXPECT_DOUBLE_EQ(scene.breakage->minBreakableVolume, 5e-11);
  // The grain (1.6 mm, 2.1e-9 m^3) is breakable and 400 times the fines size.
  EXPECT_GT(scene.shapes[0]->volume(), 2e-9);
  EXPECT_LT(scene.shapes[0]->volume(), 2.3e-9);

  s.formulation = lsdem::dynamics::ForceFormulation::AreaWeighted;
  std::ofstream(path) << breakageSceneText(c, s, 55);
  const lsdem::io::AnySceneDef anyAw = lsdem::io::readScene(path.string());
  EXPECT_DOUBLE_EQ(std::get<lsdem::io::SceneDef<3>>(anyAw).world.contact.kn, 1.28e4);  // node density does not count
}

namespace {

BreakageRun syntheticRun(const std::string& name, const std::string& knob, double cells, std::uint64_t seed,
                         double shift, double cpu) {
  BreakageRun r;
  r.caseName = name;
  r.knob = knob;
  r.knobValue = knob == "cells" ? cells : 2.0;
  r.setting.cellsAcross = cells;
  if (knob == "nodes") r.setting.nodeDensity = 2.0;
  r.seed = seed;
  r.ok = true;
  // A seed moves the curve by 10 % of a decade per seed; a setting by `shift` decades.
  const double f = std::pow(10.0, 0.1 * double(seed) + shift);
  r.psd = {{1e-4 * f, 1e-3 * f}, {0.5, 1.0}};
  r.d50 = 1e-4 * f;
  r.fragments = 10;
  r.peakStress = 1e4 * (1 + shift);
  r.splitStress = 0.5e4 * (1 + shift);
  r.cpuSeconds = cpu;
  r.maxRssMiB = 20;
  return r;
}

}  // namespace

TEST(BreakageAccuracy, SummaryMeasuresSeedMeansAgainstTheFinestGrid) {
  BreakageReport report;
  for (const char* name : {"a", "b"}) {
    for (std::uint64_t seed : {1u, 2u}) {
      report.runs.push_back(syntheticRun(name, "cells", 10, seed, 0.2, 1.0));
      report.runs.push_back(syntheticRun(name, "cells", 20, seed, 0.05, 4.0));
      report.runs.push_back(syntheticRun(name, "cells", 40, seed, 0.0, 16.0));
      report.runs.push_back(syntheticRun(name, "nodes", 20, seed, 0.1, 2.0));
    }
  }
  summariseBreakage(report);
  ASSERT_EQ(report.rows.size(), 8u);
  // Paired: each run against the 40-cell run of its seed, exactly its shift;
  // the mean curves are shifted alike.
  for (const BreakageRun& r : report.runs) {
    const double expected = r.knob == "nodes"               ? 0.1
                            : r.setting.cellsAcross == 10.0 ? 0.2
                            : r.setting.cellsAcross == 20.0 ? 0.05
                                                            : 0.0;
    EXPECT_NEAR(r.psdError, expected, 1e-12);
  }
  for (const BreakageRow& w : report.rows) {
    EXPECT_EQ(w.seeds, 2);
    EXPECT_EQ(w.reference, w.knob == "cells" && w.setting.cellsAcross == 40);
    EXPECT_NEAR(w.pairedPsdError.spread, 0.0, 1e-12);
    EXPECT_NEAR(w.psdError, w.pairedPsdError.mean, 1e-12);
  }
  // Seed noise: the two seeds' curves are 0.1 decade apart; the floor of two-seed means 0.1 / sqrt 2.
  ASSERT_EQ(report.seedNoise.size(), 2u);
  EXPECT_NEAR(report.seedNoise[0].second.mean, 0.1, 1e-12);
  EXPECT_NEAR(report.noiseFloor[0].second, 0.1 / std::sqrt(2.0), 1e-12);
  // Orders: 0.2 at 10 cells, 0.05 at 20: order 2.
  for (const ConvergenceOrder& o : report.orders) {
    if (o.metric == "psd_l1") {
      EXPECT_EQ(o.points, 2);
      EXPECT_NEAR(o.order, 2.0, 1e-9);
    }
  }
  // Budgets at 3, 2, 1 x 0.0707 decades: 10 cells (0.2, 2 s), nodes 2 (0.1, 4 s), 20 cells (0.05, 8 s).
  ASSERT_EQ(report.budgets.size(), 3u);
  EXPECT_EQ(report.budgets[0].name, "fast");
  EXPECT_DOUBLE_EQ(report.budgets[0].setting.cellsAcross, 10);
  EXPECT_NEAR(report.budgets[0].cpuSeconds, 2.0, 1e-12);
  EXPECT_EQ(report.budgets[1].knob, "nodes");
  EXPECT_DOUBLE_EQ(report.budgets[2].setting.cellsAcross, 20);
  EXPECT_NEAR(report.budgets[2].psdError, 0.05, 1e-12);
  EXPECT_FALSE(report.budgets[2].isReference);
  EXPECT_NE(breakageMarkdown(report).find("| publication | 0.0707 | cells 20, nodes 1, per_node, regrid 0"),
            std::string::npos)
      << breakageMarkdown(report);
}

// The orders of d50 and of the stress at the first split are measured
// against the reference row wherever the runs list it: here the finest grid
// comes first, so sorting the rows moves it.
TEST(BreakageAccuracy, OrdersAreAgainstTheReferenceWhateverTheRunOrder) {
  BreakageReport report;
  for (std::uint64_t seed : {1u, 2u}) {
    report.runs.push_back(syntheticRun("a", "cells", 40, seed, 0.0, 16.0));
    report.runs.push_back(syntheticRun("a", "nodes", 20, seed, 0.1, 2.0));
    report.runs.push_back(syntheticRun("a", "cells", 10, seed, 0.2, 1.0));
    report.runs.push_back(syntheticRun("a", "cells", 20, seed, 0.05, 4.0));
  }
  summariseBreakage(report);
  // d50 of a shift s: 10^s times the reference's; the split stress (1 + s) times.
  const double d50Order = std::log((std::pow(10.0, 0.2) - 1) / (std::pow(10.0, 0.05) - 1)) / std::log(2.0);
  int checked = 0;
  for (const ConvergenceOrder& o : report.orders) {
    if (o.metric == "d50") {
      EXPECT_EQ(o.points, 2);
      EXPECT_NEAR(o.order, d50Order, 1e-9);
      ++checked;
    }
    if (o.metric == "split_stress" || o.metric == "peak_stress") {
      EXPECT_EQ(o.points, 2) << o.metric;
      EXPECT_NEAR(o.order, 2.0, 1e-9) << o.metric;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 3);
  for (const BreakageRow& w : report.rows) {
    const double shift = w.reference ? 0.0 : w.knob == "nodes" ? 0.1 : w.setting.cellsAcross == 10 ? 0.2 : 0.05;
    EXPECT_NEAR(w.splitStress.mean, 0.5e4 * (1 + shift), 1e-9);
  }
}

TEST(BreakageAccuracy, MeanDistributionAveragesThePassingFractions) {
  const SizeDistribution a{{1e-4, 1e-3}, {0.5, 1.0}}, b{{2e-4, 1e-3}, {0.2, 1.0}};
  const SizeDistribution m = meanDistribution({a, b});
  ASSERT_EQ(m.size.size(), 3u);
  EXPECT_DOUBLE_EQ(m.passing[0], 0.25);  // a passes 0.5, b nothing yet
  EXPECT_DOUBLE_EQ(m.passing[1], 0.35);
  EXPECT_DOUBLE_EQ(m.passing[2], 1.0);
}
