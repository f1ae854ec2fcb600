// Stability of contacts and integration in hard cases (short versions of the
// cases in lsdem/study/Stability.h): mass ratio 1e4, a kinematic tool
// crushing a bed, impact at 10 x the usual speed, grid edges and degenerate
// inertia, and a settled packing with breakage enabled.

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
  EXPECT_EQ(r.escaped, 0u);
  EXPECT_EQ(r.unsafeDtSteps, 0u);
  EXPECT_LE(r.maxMassError, 1e-9);
  EXPECT_GT(r.steps, 0u);
}

}  // namespace

TEST(StabilityContacts, MassRatio2D) { expectStable(massRatioCase<2>(CaseLength::Short)); }
TEST(StabilityContacts, MassRatio3D) { expectStable(massRatioCase<3>(CaseLength::Short)); }
TEST(StabilityContacts, ToolCrush2D) { expectStable(toolCrushCase<2>(CaseLength::Short)); }
TEST(StabilityContacts, ToolCrush3D) { expectStable(toolCrushCase<3>(CaseLength::Short)); }
TEST(StabilityContacts, Impact2D) { expectStable(impactCase<2>(CaseLength::Short)); }
TEST(StabilityContacts, Impact3D) { expectStable(impactCase<3>(CaseLength::Short)); }
TEST(StabilityContacts, GridEdge2D) { expectStable(gridEdgeCase<2>(CaseLength::Short)); }
TEST(StabilityContacts, GridEdge3D) { expectStable(gridEdgeCase<3>(CaseLength::Short)); }
TEST(StabilityContacts, Settled2D) { expectStable(settledCase<2>(CaseLength::Short)); }
TEST(StabilityContacts, Settled3D) { expectStable(settledCase<3>(CaseLength::Short)); }

// The monitor's invariants catch what they claim to: a result with each kind
// of violation fails with one line per violation.
TEST(StabilityContacts, CheckInvariantsReportsEachViolation) {
  StabilityResult r;
  r.name = "synthetic";
  checkInvariants(r);
  EXPECT_TRUE(r.passed());
  r.nonFinite = 1;
  r.maxEnergyExcess = 0.02;
  r.maxSplitMassError = 1e-11;
  r.maxMassError = 1e-8;
  r.maxOverlapFraction = 0.2;
  r.escaped = 2;
  r.unsafeDtSteps = 3;
  r.minBreakages = 5;
  checkInvariants(r);
  EXPECT_EQ(r.failures.size(), 8u);
  r.overlapLimit = 0.25;
  checkInvariants(r);
  EXPECT_EQ(r.failures.size(), 7u);  // 0.2 is within 0.25
}
