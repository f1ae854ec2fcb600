/// @file BreakageSummary.cpp
/// @brief The summaries of the breakage study (BreakageAccuracy.h): each run's
/// PSD error against its reference, the rows over seeds, the seed noise, the
/// observed orders and the recommended budgets.

#include "lsdem/study/BreakageAccuracy.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace lsdem::study {
namespace {

bool sameSetting(const BreakageSetting& a, const BreakageSetting& b) {
  return a.cellsAcross == b.cellsAcross && a.nodeDensity == b.nodeDensity && a.formulation == b.formulation &&
         a.regridCells == b.regridCells;
}

// The reference setting: the finest grid of the ladder, other knobs at the baseline.
BreakageSetting referenceSetting(const std::vector<BreakageRun>& runs) {
  BreakageSetting ref;
  ref.cellsAcross = 0.0;
  for (const BreakageRun& r : runs) {
    if (r.knob == "cells") ref.cellsAcross = std::max(ref.cellsAcross, r.setting.cellsAcross);
  }
  return ref;
}

double relative(double value, double reference) {
  return reference != 0.0 ? std::abs(value / reference - 1.0) : std::abs(value);
}

// The budgets' PSD error bounds as multiples of the noise floor (mean over
// the cases of the expected distance between two means of as many seeds):
// at 1x the setting's mean curve is as near the finest grid's as another set
// of seeds at the finest grid would be.
struct BudgetTarget {
  const char* name;
  double ofNoise;
};
constexpr BudgetTarget kBudgets[] = {{"fast", 3.0}, {"balanced", 2.0}, {"publication", 1.0}};

}  // namespace

MeanSpread meanSpread(const std::vector<double>& values) {
  MeanSpread m;
  if (values.empty()) return m;
  for (double v : values) m.mean += v;
  m.mean /= double(values.size());
  if (values.size() > 1) {
    double ss = 0.0;
    for (double v : values) ss += (v - m.mean) * (v - m.mean);
    m.spread = std::sqrt(ss / double(values.size() - 1));
  }
  return m;
}

ConvergenceOrder fitOrder(const std::vector<double>& cells, const std::vector<double>& errors) {
  ConvergenceOrder o;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < cells.size() && i < errors.size(); ++i) {
    if (!(errors[i] > 0.0) || !(cells[i] > 0.0)) continue;
    const double x = std::log(cells[i]), y = std::log(errors[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    ++o.points;
  }
  if (o.points < 2) return o;
  const double n = o.points, den = n * sxx - sx * sx;
  if (den > 0.0) o.order = -(n * sxy - sx * sy) / den;
  return o;
}

void summariseBreakage(BreakageReport& report) {
  report.rows.clear();
  report.seedNoise.clear();
  report.noiseFloor.clear();
  report.orders.clear();
  report.budgets.clear();
  const BreakageSetting ref = referenceSetting(report.runs);

  // Each run's PSD error: against the reference run of its case and seed.
  std::map<std::pair<std::string, std::uint64_t>, const BreakageRun*> references;
  for (const BreakageRun& r : report.runs) {
    if (r.ok && r.knob == "cells" && sameSetting(r.setting, ref)) references[{r.caseName, r.seed}] = &r;
  }
  for (BreakageRun& r : report.runs) {
    const auto it = references.find({r.caseName, r.seed});
    r.psdError = r.ok && it != references.end() ? psdDistance(r.psd, it->second->psd) : std::nan("");
  }

  // The rows: one per case, knob and value, over the seeds that finished.
  std::vector<std::string> caseOrder;
  for (const BreakageRun& r : report.runs) {
    if (std::find(caseOrder.begin(), caseOrder.end(), r.caseName) == caseOrder.end()) caseOrder.push_back(r.caseName);
  }
  std::map<std::string, std::size_t> knobRank = {{"cells", 0}, {"nodes", 1}, {"law", 2}, {"regrid", 3}};
  for (const std::string& name : caseOrder) {
    std::vector<BreakageRow> rows;
    for (const BreakageRun& r : report.runs) {
      if (r.caseName != name) continue;
      auto it = std::find_if(rows.begin(), rows.end(),
                             [&](const BreakageRow& w) { return w.knob == r.knob && w.knobValue == r.knobValue; });
      if (it == rows.end()) {
        BreakageRow w;
        w.caseName = name;
        w.knob = r.knob;
        w.knobValue = r.knobValue;
        w.setting = r.setting;
        w.reference = r.knob == "cells" && sameSetting(r.setting, ref);
        rows.push_back(w);
      }
    }
    for (BreakageRow& w : rows) {
      std::vector<double> err, d10, d50, d90, frag, fines, circ, aspect, peak, split, cpu;
      std::vector<SizeDistribution> curves;
      for (const BreakageRun& r : report.runs) {
        if (r.caseName != name || r.knob != w.knob || r.knobValue != w.knobValue || !r.ok) continue;
        ++w.seeds;
        if (std::isfinite(r.psdError)) err.push_back(r.psdError);
        curves.push_back(r.psd);
        d10.push_back(r.d10);
        d50.push_back(r.d50);
        d90.push_back(r.d90);
        frag.push_back(r.fragments);
        fines.push_back(r.finesPercent);
        circ.push_back(r.meanCircularity);
        aspect.push_back(r.meanAspectRatio);
        peak.push_back(r.peakStress);
        if (std::isfinite(r.splitStress)) split.push_back(r.splitStress);
        cpu.push_back(r.cpuSeconds);
        w.maxRssMiB = std::max(w.maxRssMiB, r.maxRssMiB);
      }
      w.pairedPsdError = meanSpread(err);
      if (!curves.empty()) w.meanPsd = meanDistribution(curves);
      w.d10 = meanSpread(d10);
      w.d50 = meanSpread(d50);
      w.d90 = meanSpread(d90);
      w.fragments = meanSpread(frag);
      w.finesPercent = meanSpread(fines);
      w.circularity = meanSpread(circ);
      w.aspectRatio = meanSpread(aspect);
      w.peakStress = meanSpread(peak);
      w.splitStress = meanSpread(split);
      w.cpuSeconds = meanSpread(cpu);
    }
    const auto refRow = std::find_if(rows.begin(), rows.end(), [](const BreakageRow& w) { return w.reference; });
    if (refRow != rows.end()) {
      const double refPeak = refRow->peakStress.mean, refFragments = refRow->fragments.mean;
      for (BreakageRow& w : rows) {
        w.psdError = w.seeds > 0 && refRow->seeds > 0 ? psdDistance(w.meanPsd, refRow->meanPsd) : std::nan("");
        w.peakStressError = relative(w.peakStress.mean, refPeak);
        w.fragmentsError = relative(w.fragments.mean, refFragments);
      }
    }
    std::stable_sort(rows.begin(), rows.end(), [&](const BreakageRow& a, const BreakageRow& b) {
      if (a.knob != b.knob) return knobRank[a.knob] < knobRank[b.knob];
      return a.knobValue < b.knobValue;
    });

    // The seed noise: the L1 distance between the reference runs of every two seeds.
    std::vector<const BreakageRun*> refs;
    for (const auto& [key, run] : references) {
      if (key.first == name) refs.push_back(run);
    }
    std::vector<double> pairs;
    for (std::size_t i = 0; i < refs.size(); ++i) {
      for (std::size_t j = i + 1; j < refs.size(); ++j) pairs.push_back(psdDistance(refs[i]->psd, refs[j]->psd));
    }
    const MeanSpread noise = meanSpread(pairs);
    report.seedNoise.push_back({name, noise});
    report.noiseFloor.push_back({name, refs.empty() ? 0.0 : noise.mean / std::sqrt(double(refs.size()))});

    // The observed orders over the grid ladder (the reference left out).
    std::vector<double> cells, psd, d50, peak, split, frag;
    // The reference row again: the sort above moved the rows under refRow.
    const auto refSorted = std::find_if(rows.begin(), rows.end(), [](const BreakageRow& w) { return w.reference; });
    const double refD50 = refSorted != rows.end() ? refSorted->d50.mean : 0.0;
    const double refSplit = refSorted != rows.end() ? refSorted->splitStress.mean : 0.0;
    for (const BreakageRow& w : rows) {
      if (w.knob != "cells" || w.reference || w.seeds == 0) continue;
      cells.push_back(w.setting.cellsAcross);
      psd.push_back(w.psdError);
      d50.push_back(relative(w.d50.mean, refD50));
      peak.push_back(w.peakStressError);
      split.push_back(relative(w.splitStress.mean, refSplit));
      frag.push_back(w.fragmentsError);
    }
    for (const auto& [metric, errors] : std::vector<std::pair<std::string, std::vector<double>>>{
             {"psd_l1", psd}, {"d50", d50}, {"peak_stress", peak}, {"split_stress", split}, {"fragments", frag}}) {
      ConvergenceOrder o = fitOrder(cells, errors);
      o.caseName = name;
      o.metric = metric;
      report.orders.push_back(o);
    }
    report.rows.insert(report.rows.end(), rows.begin(), rows.end());
  }

  // The budgets: a setting's error is the mean over the cases of its mean PSD
  // error, its cost the sum over the cases of its mean CPU time.
  double noise = 0.0;
  for (const auto& [name, floor] : report.noiseFloor) noise += floor / double(report.noiseFloor.size());
  struct Candidate {
    const BreakageRow* first = nullptr;
    double error = 0.0, cpu = 0.0, rss = 0.0;
    int cases = 0;
    std::vector<std::pair<std::string, double>> cpuByCase;
  };
  std::vector<Candidate> candidates;
  for (const BreakageRow& w : report.rows) {
    auto it = std::find_if(candidates.begin(), candidates.end(), [&](const Candidate& c) {
      return c.first->knob == w.knob && c.first->knobValue == w.knobValue;
    });
    if (it == candidates.end()) {
      Candidate c;
      c.first = &w;
      candidates.push_back(c);
      it = candidates.end() - 1;
    }
    if (w.seeds == 0 || !std::isfinite(w.psdError)) continue;
    it->error += w.psdError;
    it->cpu += w.cpuSeconds.mean;
    it->rss = std::max(it->rss, w.maxRssMiB);
    it->cpuByCase.push_back({w.caseName, w.cpuSeconds.mean});
    ++it->cases;
  }
  for (const BudgetTarget& t : kBudgets) {
    BreakageBudget b;
    b.name = t.name;
    b.target = t.ofNoise * noise;
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates) {
      if (c.cases != int(caseOrder.size()) || c.cases == 0) continue;
      if (c.error / c.cases > b.target) continue;
      if (!best || c.cpu < best->cpu) best = &c;
    }
    if (best) {
      b.reached = true;
      b.isReference = best->first->reference;
      b.knob = best->first->knob;
      b.knobValue = best->first->knobValue;
      b.setting = best->first->setting;
      b.psdError = best->error / best->cases;
      b.cpuSeconds = best->cpu;
      b.maxRssMiB = best->rss;
      b.cpuByCase = best->cpuByCase;
    }
    report.budgets.push_back(b);
  }

  // Notes for the table.
  const bool one = caseOrder.size() == 1;
  const std::string scenes = one ? "the scene" : "the " + std::to_string(caseOrder.size()) + " scenes";
  report.notes = {
      "PSD error: L1 distance over log10(sieve size), in decades, between the setting's mean cumulative mass "
      "curve over its seeds and the reference's (finest grid, same seeds); sieve sizes below 10 um count as "
      "10 um. Paired: each run against the reference run of the same seed, mean +- spread (sample standard "
      "deviation) over the seeds.",
      "Seed noise: the distance between single reference runs of two seeds (every pair): what another draw of "
      "Weibull strengths changes. Noise floor: that over sqrt(seeds), the expected distance between two means of "
      "as many independent runs; PSD errors near it are not resolved by this many seeds.",
      report.dimension == 3
          ? "The contact stiffness per unit contact area is held at the shipped scene's on every grid (kn scaled "
            "by (cells_shipped / cells)^2, and / node_density^2 under the per-node law)."
          : "The contact stiffness per unit contact length is held at the shipped scene's on every grid (kn scaled "
            "by cells_shipped / cells, and / node_density under the per-node law).",
      "Budgets: the cheapest setting whose PSD error" + std::string(one ? "" : ", averaged over " + scenes + ",") +
          " is at most 3x (fast), 2x (balanced) and 1x (publication) the " + (one ? "" : "mean ") +
          "noise floor; cost = " +
          (one ? "the scene's mean CPU seconds" : "the sum of " + scenes + "' mean CPU seconds") +
          " of one run on one thread.",
  };
}

}  // namespace lsdem::study
