#include "lsdem/io/RunSummary.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <sstream>

using namespace lsdem;

// A short run with gravity and a floor: the summary names the declared
// effects only and carries the counts and the energy budget.
TEST(RunSummary, ListsDeclaredEffectsStagesAndBudget) {
  dynamics::WorldDef<2> def;
  def.gravity = geometry::Vec<2>(0.0, -9.81);
  dynamics::World<2> world(def);
  dynamics::PlaneDef<2> floor;
  floor.plane.normal = geometry::Vec<2>::UnitY();
  world.addPlane(floor);
  geometry::ShapeDef<2> shape;
  shape.radius = 0.05;
  shape.cellsAcross = 10;
  dynamics::ParticleDef<2> p;
  p.shape = geometry::buildShape(shape);
  p.position = geometry::Vec<2>(0.0, 0.049);
  world.addParticle(p);
  world.run(50);

  std::ostringstream out;
  io::writeRunSummary(world, 0.5, out);
  const std::string json = out.str();
  EXPECT_NE(json.find("\"steps\": 50,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"particles\": 1,"), std::string::npos);
  const std::string contacts = "\"contacts\": " + std::to_string(world.contacts().pairContacts().size()) + ",";
  EXPECT_NE(json.find(contacts), std::string::npos);
  const std::string certified =
      "\"certified_walks_last_step\": " + std::to_string(world.contacts().certifiedWalks()) + ",";
  const std::string leafOnly = "\"leaf_walks_last_step\": " + std::to_string(world.contacts().leafWalks()) + ",";
  const std::string frontier =
      "\"frontier_walks_last_step\": " + std::to_string(world.contacts().frontierWalks());
  EXPECT_NE(json.find(frontier), std::string::npos) << json;
  EXPECT_NE(json.find(certified), std::string::npos) << json;
  EXPECT_NE(json.find(leafOnly), std::string::npos) << json;
  EXPECT_NE(json.find("\"name\": \"gravity\""), std::string::npos);
  EXPECT_EQ(json.find("damping\""), std::string::npos);  // not declared, not listed
  for (const char* stage : {"integrate", "broad_phase", "narrow_phase", "accumulate", "effects", "after_step", "energy"}) {
    EXPECT_NE(json.find(std::string("\"") + stage + "\":"), std::string::npos) << stage;
  }
  EXPECT_NE(json.find("\"relative_balance_error\""), std::string::npos);
}
