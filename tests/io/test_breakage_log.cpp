#include "lsdem/io/BreakageLog.h"

#include <gtest/gtest.h>

#include <sstream>

using namespace lsdem;

// Columns and units as documented, one row per event, lists joined by ';',
// numbers that read back exactly.
TEST(BreakageLog, HeaderAndRows3D) {
  breakage::BreakageEvent<3> e;
  e.time = 0.125;
  e.parent = 7;
  e.children = {11, 12, 13};
  e.criterionValue = 4.2e7;
  e.strength = 4.0e7;
  e.planeNormal = geometry::Vec<3>(0.0, 0.6, 0.8);
  e.planeOffset = -0.001;
  e.childVolumes = {1.0e-9, 2.5e-9};
  e.finesVolumes = {3.0e-12};
  e.rawVolumeError = -3.1e-4;
  e.parentMass = 9.2e-6;
  e.fragmentMass = 9.2e-6;
  // The energy check: measured for the second event only (the first one's
  // contacts were stale: empty cells). Gain = 0.25 + 1.5 - 0.5 - 1 - 0.125.
  breakage::BreakageEvent<3> checked = e;
  checked.parentKineticEnergy = 0.5;
  checked.parentSpringEnergy = 1.0;
  checked.fragmentKineticEnergy = 0.25;
  checked.fragmentSpringEnergy = 1.5;
  checked.inertiaEnergyBound = 0.125;
  std::ostringstream out;
  io::writeBreakageLogHeader<3>(out);
  const std::vector<breakage::BreakageEvent<3>> events{e, checked};
  io::writeBreakageLogRows<3>(events, out);
  const std::string text = out.str();
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "time_s,parent_id,child_ids,criterion_value_Pa,strength_Pa,manual,buckling,normal_x,normal_y,normal_z,"
            "plane_offset_m,child_volumes_m3,fines_volumes_m3,raw_volume_error,parent_mass_kg,fragment_mass_kg,"
            "parent_energy_J,fragment_energy_J,energy_gain_J,mode,chip_depth_m");
  const std::string row = "0.125,7,11;12;13,4.2e+07,4e+07,0,0,0,0.6,0.8,-0.001,1e-09;2.5e-09,3e-12,-0.00031,9.2e-06,9.2e-06";
  EXPECT_EQ(text, text.substr(0, text.find('\n') + 1) + row + ",,,,split,\n" + row + ",1.5,1.75,0.125,split,\n");
}

// The mode column names how each particle broke; a chip gives its depth.
TEST(BreakageLog, ModeAndChipDepth) {
  std::vector<breakage::BreakageEvent<2>> events(4);
  events[1].buckling = true;
  events[2].manual = true;
  events[3].chip = true;
  events[3].chipDepth = 2.5e-4;
  std::ostringstream out;
  io::writeBreakageLogRows<2>(events, out);
  std::istringstream in(out.str());
  std::string line;
  std::vector<std::string> tails;
  while (std::getline(in, line)) {
    const std::size_t mode = line.rfind(',', line.rfind(',') - 1);
    tails.push_back(line.substr(mode + 1));
  }
  EXPECT_EQ(tails, (std::vector<std::string>{"split,", "buckling,", "manual,", "chip,0.00025"}));
}

TEST(BreakageLog, TwoDimensionalColumns) {
  std::ostringstream out;
  io::writeBreakageLogHeader<2>(out);
  EXPECT_NE(out.str().find("normal_y,plane_offset_m,child_volumes_m2"), std::string::npos);
}
