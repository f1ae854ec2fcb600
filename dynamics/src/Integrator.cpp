#include "lsdem/dynamics/Integrator.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace lsdem::dynamics {
namespace {

// sin and cos of x. The angles of a free-rotation sub-step are small (a
// grain turns by far less than 1/16 rad in a step): there Taylor series,
// whose first omitted term is below 1e-21 of the result, give both to the
// last bit or so at a fraction of the library's cost; the shorter series
// serves the usual sub-step angles, below 1/1024 rad.
inline void sinCos(double x, double& s, double& c) {
  constexpr double s3 = -1.0 / 6.0, s5 = 1.0 / 120.0, s7 = -1.0 / 5040.0, s9 = 1.0 / 362880.0,
                   s11 = -1.0 / 39916800.0;
  constexpr double c2 = -0.5, c4 = 1.0 / 24.0, c6 = -1.0 / 720.0, c8 = 1.0 / 40320.0, c10 = -1.0 / 3628800.0,
                   c12 = 1.0 / 479001600.0;
  const double a = std::abs(x), x2 = x * x;
  if (a < 0x1p-10) {
    s = x + x * x2 * (s3 + x2 * s5);
    c = 1.0 + x2 * (c2 + x2 * (c4 + x2 * c6));
  } else if (a < 0.0625) {
    s = x + x * x2 * (s3 + x2 * (s5 + x2 * (s7 + x2 * (s9 + x2 * s11))));
    c = 1.0 + x2 * (c2 + x2 * (c4 + x2 * (c6 + x2 * (c8 + x2 * (c10 + x2 * c12)))));
  } else {
    s = std::sin(x);
    c = std::cos(x);
  }
}

// Exact free rotation about body axis k for a time s: the body turns by
// a = s L_k / I_k about its own axis k (q <- q (cos a/2, sin a/2 e_k)); the
// body-frame momentum turns by -a about the same axis. One sine and cosine,
// of a/2; those of a follow by the double-angle formulas. (The axis is a
// template argument: the turns inline with their indices known.)
template <int k>
inline void rotateAboutBodyAxis(Eigen::Quaterniond& q, Vec<3>& Lbody, const Vec<3>& invInertia, double s) {
  double sh = 0.0, ch = 1.0;
  sinCos(0.5 * s * Lbody[k] * invInertia[k], sh, ch);
  constexpr int i = (k + 1) % 3, j = (k + 2) % 3;
  // q (ch, sh e_k): w' = ch w - sh v_k; v' = ch v + sh w e_k + sh v x e_k,
  // where (v x e_k)_i = v_j, (v x e_k)_j = -v_i, (v x e_k)_k = 0.
  const double w = q.w(), vi = q.vec()[i], vj = q.vec()[j], vk = q.vec()[k];
  q.w() = ch * w - sh * vk;
  q.vec()[k] = ch * vk + sh * w;
  q.vec()[i] = ch * vi + sh * vj;
  q.vec()[j] = ch * vj - sh * vi;
  const double c = ch * ch - sh * sh, sn = 2.0 * sh * ch;
  const double li = Lbody[i], lj = Lbody[j];
  Lbody[i] = c * li + sn * lj;
  Lbody[j] = c * lj - sn * li;
}

// The splitting x(dt/2), y(dt/2), z(dt), y(dt/2), x(dt/2) of the free
// rotation, on the orientations and body-frame angular momenta of `count`
// bodies. Each turn is made for all of them before the next: a body's five
// turns are one chain, each waiting for the one before, and bodies taken
// one after another left the processor waiting on it; taken together, the
// chains of different bodies overlap. (Each body's arithmetic is the same
// either way, bit for bit.)
void freeRotationBodies(Eigen::Quaterniond* q, Vec<3>* Lbody, const Vec<3>* invInertia, std::size_t count,
                        double dt) {
  const auto turn = [&]<int k>(double s) {
    for (std::size_t b = 0; b < count; ++b) rotateAboutBodyAxis<k>(q[b], Lbody[b], invInertia[b], s);
  };
  turn.template operator()<0>(0.5 * dt);
  turn.template operator()<1>(0.5 * dt);
  turn.template operator()<2>(dt);
  turn.template operator()<1>(0.5 * dt);
  turn.template operator()<0>(0.5 * dt);
  for (std::size_t b = 0; b < count; ++b) q[b].normalize();
}
void freeRotationBody(Eigen::Quaterniond& q, Vec<3>& Lbody, const Vec<3>& invInertia, double dt) {
  freeRotationBodies(&q, &Lbody, &invInertia, 1, dt);
}

// Bodies per batch of kickDrift's free rotations (freeRotationBodies).
constexpr std::ptrdiff_t kRotationBatch = 8;

// The translational half kick of particle i.
template <int D>
void kickVelocity(Particles<D>& p, std::ptrdiff_t i, double half) {
  p.velocity[i] += half * p.invMass[i] * p.force[i];
}

}  // namespace

void freeRotation(Eigen::Quaterniond& q, const Vec<3>& L, const Vec<3>& invInertia, double dt) {
  Vec<3> Lbody = q.conjugate() * L;
  freeRotationBody(q, Lbody, invInertia, dt);
}

// In 3D both halves work in the body frame, where the inertia is diagonal:
// the body-frame angular momentum I w_b is kicked by the body-frame torque,
// turned by the free rotation, and the world angular velocity is q (I^-1 L_b).
template <int D>
void kickDrift(Particles<D>& p, double dt) {
  const double half = 0.5 * dt;
  const std::ptrdiff_t n = std::ptrdiff_t(p.size());
  if constexpr (D == 2) {
#pragma omp parallel for schedule(static) if (n > 512)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      kickVelocity(p, i, half);
      p.position[i] += dt * p.velocity[i];
      p.angularVelocity[i] += half * p.invInertia[i] * p.torque[i];
      p.orientation[i] += dt * p.angularVelocity[i];
    }
  } else {
    // In batches of bodies, whose free rotations are made together.
    const std::ptrdiff_t batches = (n + kRotationBatch - 1) / kRotationBatch;
#pragma omp parallel for schedule(static) if (n > 512)
    for (std::ptrdiff_t batch = 0; batch < batches; ++batch) {
      const std::ptrdiff_t first = batch * kRotationBatch, count = std::min(kRotationBatch, n - first);
      std::array<Vec<3>, kRotationBatch> Lbody;
      for (std::ptrdiff_t b = 0; b < count; ++b) {
        const std::ptrdiff_t i = first + b;
        kickVelocity(p, i, half);
        p.position[i] += dt * p.velocity[i];
        const Eigen::Quaterniond& q = p.orientation[i];
        Lbody[std::size_t(b)] =
            p.inertia[i].cwiseProduct(q.conjugate() * p.angularVelocity[i]) + half * (q.conjugate() * p.torque[i]);
      }
      freeRotationBodies(&p.orientation[first], Lbody.data(), &p.invInertia[first], std::size_t(count), dt);
      for (std::ptrdiff_t b = 0; b < count; ++b) {
        const std::ptrdiff_t i = first + b;
        p.angularVelocity[i] = p.orientation[i] * Vec<3>(p.invInertia[i].cwiseProduct(Lbody[std::size_t(b)]));
      }
    }
  }
}

template <int D>
void kick(Particles<D>& p, double dt) {
  const double half = 0.5 * dt;
  const std::ptrdiff_t n = std::ptrdiff_t(p.size());
#pragma omp parallel for schedule(static) if (n > 512)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    kickVelocity(p, i, half);
    if constexpr (D == 2) {
      p.angularVelocity[i] += half * p.invInertia[i] * p.torque[i];
    } else {
      const Eigen::Quaterniond& q = p.orientation[i];
      p.angularVelocity[i] += q * Vec<3>(p.invInertia[i].cwiseProduct(q.conjugate() * (half * p.torque[i])));
    }
  }
}

template void kickDrift<2>(Particles<2>&, double);
template void kickDrift<3>(Particles<3>&, double);
template void kick<2>(Particles<2>&, double);
template void kick<3>(Particles<3>&, double);

}  // namespace lsdem::dynamics
