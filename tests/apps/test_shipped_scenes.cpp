// Every scene shipped in apps/scenes/ runs: a few steps of each (`lsdem run
// --steps 3`) exit with code 0 and write a summary.json that counts them. A
// scene, shape, mesh or asset that no longer loads fails here, not in a
// long script run.

#include "support/Files.h"
#include "support/Process.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

using lsdem::test::readFile;

namespace {

std::vector<fs::path> shippedScenes() {
  std::vector<fs::path> scenes;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(LSDEM_SOURCE_DIR) / "apps" / "scenes")) {
    if (e.path().extension() == ".toml") scenes.push_back(e.path());
  }
  std::sort(scenes.begin(), scenes.end());
  return scenes;
}

class ShippedScene : public ::testing::TestWithParam<fs::path> {};

}  // namespace

TEST_P(ShippedScene, RunsAFewSteps) {
  const fs::path scene = GetParam();
  const fs::path out = lsdem::test::tempPath("lsdem_test_shipped_" + scene.stem().string());
  fs::remove_all(out);
  const lsdem::test::ProcessResult r = lsdem::test::runCaptured(
      {LSDEM_BINARY, "run", scene.string(), "--out", out.string(), "--steps", "3", "--threads", "1", "--quiet"});
  EXPECT_EQ(r.code, 0) << scene << "\n" << r.output;
  const std::string summary = readFile(out / "summary.json");
  EXPECT_NE(summary.find("\"steps\": 3,"), std::string::npos) << scene << "\n" << summary.substr(0, 400);
  EXPECT_NE(summary.find("\"stopped_early\": false"), std::string::npos) << scene;
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedScene, ::testing::ValuesIn(shippedScenes()),
                         [](const ::testing::TestParamInfo<fs::path>& info) { return info.param.stem().string(); });

// The folder holds the scenes the README lists (a scene lost from the tree
// would otherwise just drop out of the test above).
TEST(ShippedScenes, AreThere) {
  const std::vector<fs::path> scenes = shippedScenes();
  EXPECT_GE(scenes.size(), 10u);
  for (const char* name : {"three_grains_2d.toml", "three_grains_3d.toml", "jaw_crusher_css80.toml",
                           "oedometer_2d.toml", "oedometer_3d.toml", "demolition.toml", "ct_grains.toml",
                           "single_grain_3d.toml"}) {
    EXPECT_TRUE(std::any_of(scenes.begin(), scenes.end(), [&](const fs::path& p) { return p.filename() == name; }))
        << name;
  }
}
