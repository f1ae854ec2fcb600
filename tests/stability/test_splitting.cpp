// Stability of the splitter and of splits in a running world (short versions
// of the cases in lsdem/study/Stability.h): every invariant holds.

#include "lsdem/study/Stability.h"

#include <gtest/gtest.h>

#include <cstdio>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace lsdem::study;

namespace {

// The cases are small (tens of particles): one thread each, so the suite's
// wall time does not depend on how busy the other cores are (waiting OpenMP
// threads on a loaded machine made a 1 s case take 30 s). Results are the
// same for any thread count.
#ifdef _OPENMP
const int kOneThread = (omp_set_num_threads(1), 1);
#endif

void expectStable(const StabilityResult& r) {
  std::printf("%s\n%s\n", stabilityTableHeader().c_str(), stabilityTableRow(r).c_str());
  for (const auto& f : r.failures) ADD_FAILURE() << r.name << " " << r.dimension << "D: " << f;
  EXPECT_TRUE(r.passed());
  EXPECT_EQ(r.nonFinite, 0u);
  EXPECT_LE(r.maxSplitMassError, 1e-12);
  EXPECT_GE(r.breakages, r.minBreakages);
}

}  // namespace

// Fragments at the resolution limit, slivers, grazing/missing cuts, cuts
// through nodes and the centroid, concave grains, degenerate contact sets.
TEST(StabilitySplitting, SplitterLimits2D) { expectStable(splitLimitsCase<2>(CaseLength::Short)); }
TEST(StabilitySplitting, SplitterLimits3D) { expectStable(splitLimitsCase<3>(CaseLength::Short)); }

// Grains in hard contact split by manual planes: fragments start overlapping others.
TEST(StabilitySplitting, SplitInContact2D) { expectStable(splitInContactCase<2>(CaseLength::Short)); }
TEST(StabilitySplitting, SplitInContact3D) { expectStable(splitInContactCase<3>(CaseLength::Short)); }

// A crushing cascade in a closed box down to fines.
TEST(StabilitySplitting, Cascade2D) { expectStable(cascadeCase<2>(CaseLength::Short)); }
TEST(StabilitySplitting, Cascade3D) { expectStable(cascadeCase<3>(CaseLength::Short)); }
