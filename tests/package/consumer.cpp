// Built against the installed lsdem package: a sphere dropped on a floor
// settles on it; exits 0 when it rests there (centre within 2 % of its
// radius above the floor, speed under 1 cm/s against the 0.77 m/s it lands with).
#include <lsdem/dynamics/World.h>
#include <lsdem/geometry/ShapeDef.h>

#include <cmath>
#include <cstdio>

int main() {
  using namespace lsdem;
  using geometry::Vec;
  geometry::ShapeDef<3> shape;
  shape.kind = geometry::ShapeKind::Sphere;
  shape.radius = 0.05;
  shape.cellsAcross = 12;
  dynamics::WorldDef<3> def;
  def.gravity = Vec<3>(0.0, 0.0, -9.81);
  def.globalDamping = 20.0;
  dynamics::World<3> world(def);
  dynamics::PlaneDef<3> floor;
  floor.name = "floor";
  floor.plane.point = Vec<3>::Zero();
  floor.plane.normal = Vec<3>::UnitZ();
  world.addPlane(floor);
  dynamics::ParticleDef<3> grain;
  grain.shape = geometry::buildShape(shape);
  grain.position = Vec<3>(0.0, 0.0, 0.08);
  world.addParticle(grain);
  while (world.time() < 0.6) world.step();
  const double z = world.particles().position[0].z();
  const double speed = world.particles().velocity[0].norm();
  std::printf("lsdem consumer: sphere centre at z = %.5f m, speed %.2e m/s after %.3f s\n", z, speed, world.time());
  return std::abs(z - 0.05) < 0.02 * 0.05 && speed < 1e-2 ? 0 : 1;
}
