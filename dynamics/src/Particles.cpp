#include "lsdem/dynamics/Particles.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::dynamics {

template <int D>
std::size_t Particles<D>::add(const ParticleDef<D>& def) {
  if (!def.shape) throw std::invalid_argument("a particle needs a shape");
  if (!(def.density > 0.0) || !std::isfinite(def.density)) {
    throw std::invalid_argument("particle density must be positive, got " + std::to_string(def.density));
  }
  if (!(def.massScale > 0.0) || !std::isfinite(def.massScale)) {
    throw std::invalid_argument("particle massScale must be positive, got " + std::to_string(def.massScale));
  }
  const auto& mp = def.shape->mass();
  const double rho = def.density * def.massScale;
  double m = rho * mp.volume;
  Spin<D> I;
  if constexpr (D == 2) {
    I = rho * mp.polarMoment();
  } else {
    I = rho * mp.principalInertia();
  }
  if (def.mass != 0.0) {
    bool positive;
    if constexpr (D == 2) {
      positive = def.inertia > 0.0 && std::isfinite(def.inertia);
    } else {
      positive = (def.inertia.array() > 0.0).all() && def.inertia.allFinite();
    }
    if (!(def.mass > 0.0) || !std::isfinite(def.mass) || !positive) {
      throw std::invalid_argument("a particle's given mass and inertia must be positive, got mass " +
                                  std::to_string(def.mass));
    }
    m = def.mass;
    I = def.inertia;
  }

  position.push_back(def.position);
  orientation.push_back(def.orientation);
  velocity.push_back(def.velocity);
  angularVelocity.push_back(def.angularVelocity);
  force.push_back(Vec<D>::Zero());
  torque.push_back(Rotation<D>::zeroSpin());

  mass.push_back(m);
  invMass.push_back(1.0 / m);
  inertia.push_back(I);
  if constexpr (D == 2) {
    invInertia.push_back(1.0 / I);
  } else {
    invInertia.push_back(I.cwiseInverse());
  }
  shape.push_back(def.shape);
  material.push_back(def.material);
  strength.push_back(def.strength);

  if (def.id == kNoParent) {
    id.push_back(nextId_++);
  } else {
    id.push_back(def.id);
    nextId_ = std::max(nextId_, def.id + 1);
  }
  parentId.push_back(def.parent);
  generation.push_back(def.generation);
  birthTime.push_back(def.birthTime);
  return size() - 1;
}

namespace {
template <class T>
void swapRemove(std::vector<T>& v, std::size_t i) {
  if (i + 1 != v.size()) v[i] = std::move(v.back());
  v.pop_back();
}
}  // namespace

template <int D>
void Particles<D>::remove(std::size_t i) {
  if (i >= size()) throw std::out_of_range("particle index " + std::to_string(i) + " out of range");
  swapRemove(position, i);
  swapRemove(orientation, i);
  swapRemove(velocity, i);
  swapRemove(angularVelocity, i);
  swapRemove(force, i);
  swapRemove(torque, i);
  swapRemove(mass, i);
  swapRemove(invMass, i);
  swapRemove(inertia, i);
  swapRemove(invInertia, i);
  swapRemove(shape, i);
  swapRemove(material, i);
  swapRemove(strength, i);
  swapRemove(id, i);
  swapRemove(parentId, i);
  swapRemove(generation, i);
  swapRemove(birthTime, i);
}

template <int D>
double Particles<D>::rotationalEnergy(std::size_t i) const {
  if constexpr (D == 2) {
    return 0.5 * inertia[i] * angularVelocity[i] * angularVelocity[i];
  } else {
    const Vec<3> wBody = orientation[i].conjugate() * angularVelocity[i];
    return 0.5 * (inertia[i].array() * wBody.array().square()).sum();
  }
}

template <int D>
void Particles<D>::saveState(
    StateWriter& out, const std::function<std::uint32_t(const std::shared_ptr<const geometry::Shape<D>>&)>& shapeIndex) const {
  out.putTag("particles");
  out.putVector(position);
  out.putVector(orientation);
  out.putVector(velocity);
  out.putVector(angularVelocity);
  out.putVector(force);
  out.putVector(torque);
  out.putVector(mass);
  out.putVector(invMass);
  out.putVector(inertia);
  out.putVector(invInertia);
  std::vector<std::uint32_t> shapes(shape.size());
  for (std::size_t i = 0; i < shape.size(); ++i) shapes[i] = shapeIndex(shape[i]);
  out.putVector(shapes);
  out.putVector(material);
  out.putVector(strength);
  out.putVector(id);
  out.putVector(parentId);
  out.putVector(generation);
  out.putVector(birthTime);
  out.put(nextId_);
}

template <int D>
void Particles<D>::loadState(StateReader& in,
                             const std::function<std::shared_ptr<const geometry::Shape<D>>(std::uint32_t)>& shapeAt) {
  in.expectTag("particles");
  in.getVector(position);
  in.getVector(orientation);
  in.getVector(velocity);
  in.getVector(angularVelocity);
  in.getVector(force);
  in.getVector(torque);
  in.getVector(mass);
  in.getVector(invMass);
  in.getVector(inertia);
  in.getVector(invInertia);
  std::vector<std::uint32_t> shapes;
  in.getVector(shapes);
  shape.resize(shapes.size());
  for (std::size_t i = 0; i < shapes.size(); ++i) shape[i] = shapeAt(shapes[i]);
  in.getVector(material);
  in.getVector(strength);
  in.getVector(id);
  in.getVector(parentId);
  in.getVector(generation);
  in.getVector(birthTime);
  nextId_ = in.get<ParticleId>();
  // Every field must describe the same particles.
  const std::size_t n = position.size();
  for (std::size_t m : {orientation.size(), velocity.size(), angularVelocity.size(), force.size(), torque.size(),
                        mass.size(), invMass.size(), inertia.size(), invInertia.size(), shape.size(), material.size(),
                        strength.size(), id.size(), parentId.size(), generation.size(), birthTime.size()}) {
    if (m != n) throw std::runtime_error("checkpoint state: particle fields of different lengths");
  }
}

template class Particles<2>;
template class Particles<3>;

}  // namespace lsdem::dynamics
