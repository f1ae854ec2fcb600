// io::overrideScene: keys of a scene replaced by dotted path, with `*` for
// every table under a parent, and one-line errors for paths that do not exist.

#include "lsdem/io/InputError.h"
#include "lsdem/io/SceneOverride.h"

#include <gtest/gtest.h>

#include <string>

using lsdem::io::InputError;
using lsdem::io::overrideScene;

namespace {

const char* kScene = R"([simulation]
dimension = 2
seed = 3

[contact]
kn = 1e5

[shapes.a]
kind = "circle"
cells_across = 40

[shapes]
b = { kind = "polygon", cells_across = 24, node_density = 1.0 }

[[particles]]
shape = "a"

[effects.breakage]
criterion = "von_mises"
)";

}  // namespace

TEST(SceneOverride, ReplacesAddsAndKeepsTheRest) {
  const std::string out = overrideScene(kScene, {{"contact.kn", "4e5"},
                                                 {"shapes.*.cells_across", "10"},
                                                 {"effects.breakage.seed", "101"},
                                                 {"contact.formulation", "\"area_weighted\""},
                                                 {"output", "{ vtk = [] }"}});
  // Parsing the result again and overriding nothing gives the same text.
  EXPECT_EQ(overrideScene(out, {}), out);
  EXPECT_NE(out.find("kn = 400000"), std::string::npos) << out;
  EXPECT_NE(out.find("formulation = 'area_weighted'"), std::string::npos) << out;
  EXPECT_NE(out.find("seed = 101"), std::string::npos) << out;
  EXPECT_NE(out.find("seed = 3"), std::string::npos) << out;  // [simulation] seed untouched
  // Both shapes, the inline table too, and nothing else.
  std::size_t n = 0;
  for (std::size_t at = out.find("cells_across = 10"); at != std::string::npos;
       at = out.find("cells_across = 10", at + 1)) {
    ++n;
  }
  EXPECT_EQ(n, 2u) << out;
  EXPECT_EQ(out.find("cells_across = 40"), std::string::npos) << out;
  EXPECT_EQ(out.find("cells_across = 24"), std::string::npos) << out;
  EXPECT_NE(out.find("node_density = 1"), std::string::npos) << out;
  EXPECT_NE(out.find("[[particles]]"), std::string::npos) << out;
}

TEST(SceneOverride, BadPathsAndValuesAreOneLineErrors) {
  const auto message = [](const std::vector<lsdem::io::SceneSetting>& s) {
    try {
      overrideScene(kScene, s, "s.toml");
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      return what;
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"nosuch.kn", "1"}}).find("no table 'nosuch'"), std::string::npos);
  EXPECT_NE(message({{"contact.kn.x", "1"}}).find("'kn' is not a table"), std::string::npos);
  EXPECT_NE(message({{"contact.*.x", "1"}}).find("matches no table"), std::string::npos);
  EXPECT_NE(message({{"contact.*", "1"}}).find("cannot be '*'"), std::string::npos);
  EXPECT_NE(message({{"contact..kn", "1"}}).find("empty part"), std::string::npos);
  EXPECT_NE(message({{"contact.kn", "1e"}}).find("bad value '1e'"), std::string::npos);
  EXPECT_NE(message({{"contact.kn", "1"}}).find("no error"), std::string::npos);
  EXPECT_THROW(overrideScene("[a\n", {}, "s.toml"), InputError);
}
