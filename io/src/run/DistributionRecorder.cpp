/// @file DistributionRecorder.cpp
/// @brief The size and shape distributions (DistributionRecorder.h).

#include "run/DistributionRecorder.h"

#include "NumberText.h"
#include "OutputNames.h"
#include "run/Specimen.h"

#include "lsdem/io/Vtk.h"

#include <algorithm>
#include <array>
#include <utility>

namespace lsdem::io {

namespace {

// Rows "prefix,size,percent passing[,mass]" of mass passing against size,
// the (size, mass) pairs sorted by size.
std::string passingRows(std::vector<std::pair<double, double>>& sizes, double total, const std::string& prefix,
                        bool withMass) {
  std::sort(sizes.begin(), sizes.end());
  double passing = 0.0;
  std::string rows;
  for (const auto& [size, mass] : sizes) {
    passing += mass;
    rows += prefix + numberText(size) + "," + numberText(100.0 * passing / total);
    if (withMass) rows += "," + numberText(mass);
    rows += '\n';
  }
  return rows;
}

}  // namespace

template <int D>
DistributionRecorder<D>::DistributionRecorder(Schedule schedule, const RunContext<D>& context)
    : Recorder<D>("distributions", std::move(schedule), context) {
  psd_ = this->addCsv(outputs::kPsd, "time_s,sieve_size_m,percent_passing");
  stats_ = this->addCsv(outputs::kShapeStats,
                        "time_s,strain,particles,mean_circularity,mean_aspect_ratio,mean_sieve_size_m,shape_particles");
  histograms_ = this->addCsv(outputs::kShapeHistograms, "time_s,strain,quantity,bin_low,bin_high,count");
}

template <int D>
void DistributionRecorder<D>::write(const World& w) {
  const RunContext<D>& c = this->context_;
  const auto& p = w.particles();
  const std::string t = numberText(w.time());
  const double h0 = c.basis.specimenHeight;
  const std::string strain =
      c.scene.specimen && h0 > 0.0 ? numberText(specimenStrain(h0, specimenHeight(*c.scene.specimen, w))) : "";
  // Particle size distribution by mass against sieve size (eq. 21).
  // Shape statistics only of the particles resolved on their grids ([output] shape_min_cells).
  std::vector<std::pair<double, double>> sizes;
  double total = 0.0, circ = 0.0, aspect = 0.0, sieve = 0.0;
  std::vector<std::size_t> resolved;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto& d = p.shape[i]->descriptors();
    sizes.emplace_back(d.sieveSize, w.unscaledMass(i));
    total += w.unscaledMass(i);
    sieve += d.sieveSize;
    if (d.equivalentDiameter >= c.scene.output.shapeMinCells * p.shape[i]->grid().spacing()) {
      resolved.push_back(i);
      circ += d.circularity;
      aspect += d.aspectRatio;
    }
  }
  // Fines removed so far count as passing at their own size (paper section
  // 3: removed particles are kept in the PSD).
  for (const dynamics::RemovedParticle& r : w.removed()) {
    if (r.reason != "fines") continue;
    sizes.emplace_back(r.sieveSize, r.mass);
    total += r.mass;
  }
  this->csv(psd_).write(passingRows(sizes, total, t + ",", false));
  const double n = double(std::max<std::size_t>(p.size(), 1));
  const double m = double(std::max<std::size_t>(resolved.size(), 1));
  this->csv(stats_).row(t + "," + strain + "," + std::to_string(p.size()) + "," + numberText(circ / m) + "," +
                        numberText(aspect / m) + "," + numberText(sieve / n) + "," + std::to_string(resolved.size()));
  // Histograms of circularity (sphericity) and aspect ratio, 10 bins on [0, 1].
  for (const bool circularity : {true, false}) {
    std::array<std::size_t, 10> bins{};
    for (const std::size_t i : resolved) {
      const auto& d = p.shape[i]->descriptors();
      bins[std::size_t(std::clamp(int((circularity ? d.circularity : d.aspectRatio) * 10.0), 0, 9))]++;
    }
    std::string out;
    for (std::size_t b = 0; b < bins.size(); ++b) {
      out += t + "," + strain + "," + (circularity ? "circularity" : "aspect_ratio") + "," + numberText(0.1 * double(b)) +
             "," + numberText(0.1 * double(b + 1)) + "," + std::to_string(bins[b]) + "\n";
    }
    this->csv(histograms_).write(out);
  }
}

// The size distribution of the particles that left through the discharge
// (a crusher's product), or through the outflow when no discharge is declared.
template <int D>
void DistributionRecorder<D>::onFinish(const World& w) {
  const std::string product = this->context_.scene.world.discharge ? "discharge" : "outflow";
  std::vector<std::pair<double, double>> sizes;
  double total = 0.0;
  for (const auto& r : w.removed()) {
    if (r.reason != product) continue;
    sizes.emplace_back(r.sieveSize, r.mass);
    total += r.mass;
  }
  if (sizes.empty()) return;
  writeFileAtomically(this->context_.out / outputs::kProductPsd,
                      "sieve_size_m,percent_passing,mass_kg\n" + passingRows(sizes, total, "", true));
}

template class DistributionRecorder<2>;
template class DistributionRecorder<3>;

}  // namespace lsdem::io
