#include "stemmap/stems/plot_figures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "stemmap/core/error.h"

namespace stemmap::stems {
namespace {

// A full turn of keyframes on the 1-m arm, looking outward, every 2°.
std::vector<StampedPose> Turn() {
  std::vector<StampedPose> keyframes;
  for (int k = 0; k < 180; ++k) {
    const double th = 2.0 * k * M_PI / 180.0;
    Eigen::Matrix3d rot;  // columns: camera x (right), y (down), z (forward) in the plot frame
    rot << std::sin(th), 0, std::cos(th), -std::cos(th), 0, std::sin(th), 0, -1, 0;
    keyframes.push_back(
        {0.2 * k, {Eigen::Quaterniond(rot), Eigen::Vector3d(std::cos(th), std::sin(th), 1.3)}});
  }
  return keyframes;
}

Stem Listed(double x, double y, double dbh_m, double confidence = 1.0, double sd_m = 0.0) {
  Stem s;
  s.centre_xy = {x, y};
  s.dbh_m = dbh_m;
  s.confidence = confidence;
  s.dbh_sd_m = sd_m;
  return s;
}

const PinholeCamera kCamera = PinholeCamera::FromHfov(960, 540, 67.0);

TEST(HiddenBehindStems, ANearWideStemHidesASectorBehindIt) {
  const Visibility none = HiddenBehindStems({}, Turn(), kCamera, 10.0);
  EXPECT_EQ(none.hidden_area_m2, 0.0);
  EXPECT_NEAR(none.plot_area_m2, M_PI * 100, 1e-9);
  const Visibility one = HiddenBehindStems({Listed(3.0, 0.0, 0.6)}, Turn(), kCamera, 10.0);
  ASSERT_EQ(one.sectors.size(), 1u);
  const HiddenSector& h = one.sectors[0];
  EXPECT_EQ(h.tree, 0);
  EXPECT_NEAR(h.azimuth_deg, 0.0, 1e-9);
  EXPECT_GT(h.from_m, 3.0);
  EXPECT_GT(h.area_m2, 0.0);
  EXPECT_NEAR(one.hidden_area_m2, h.area_m2, 1e-9);
  // The arm sees round a thinner stem sooner: its shadow is shorter.
  const double thin =
      HiddenBehindStems({Listed(3.0, 0.0, 0.2)}, Turn(), kCamera, 10.0).hidden_area_m2;
  EXPECT_LT(thin, h.area_m2);
  // Ground beyond the plot radius is not counted.
  EXPECT_LT(HiddenBehindStems({Listed(9.5, 0.0, 0.6)}, Turn(), kCamera, 10.0).hidden_area_m2, 0.5);
}

TEST(ComputePlotFigures, CertainStemsGiveTheirFiguresAndNarrowIntervals) {
  const std::vector<Stem> trees = {Listed(3, 0, 0.30), Listed(0, 5, 0.40), Listed(-6, -2, 0.20),
                                   Listed(11, 0, 0.50)};  // beyond the plot
  PlotFigureOptions o;
  o.listed_share_in_view = 1.0;  // every stem in view listed
  const PlotFigures f = ComputePlotFigures(o, trees, Visibility{{}, 0.0, M_PI * 100});
  EXPECT_EQ(f.stems, 3);
  const double area_ha = M_PI * 100 / 1e4;
  EXPECT_NEAR(f.stems_per_ha, 3 / area_ha, 1e-9);
  EXPECT_NEAR(f.basal_area_m2_per_ha, M_PI / 4 * (0.09 + 0.16 + 0.04) / area_ha, 1e-9);
  EXPECT_NEAR(f.qmd_cm, std::sqrt((900 + 1600 + 400) / 3.0), 1e-9);
  EXPECT_NEAR(f.stems_per_ha_95.low, f.stems_per_ha, 1e-9);
  EXPECT_NEAR(f.stems_per_ha_95.high, f.stems_per_ha, 1e-9);
  EXPECT_NEAR(f.basal_area_m2_per_ha_95.low, f.basal_area_m2_per_ha, 1e-9);
  EXPECT_EQ(f.expected_hidden_stems, 0.0);
}

TEST(ComputePlotFigures, DoubtAndHiddenGroundWidenTheIntervals) {
  const std::vector<Stem> trees = {Listed(3, 0, 0.30, 0.6, 0.03), Listed(0, 5, 0.40, 1.0, 0.02),
                                   Listed(-6, -2, 0.20, 0.9, 0.01), Listed(2, -7, 0.35, 1.0, 0.01)};
  const Visibility hidden{{}, 60.0, M_PI * 100};
  const PlotFigures f = ComputePlotFigures(PlotFigureOptions(), trees, hidden);
  EXPECT_LT(f.stems_per_ha_95.low, f.stems_per_ha) << "a doubtful stem may be none";
  EXPECT_GT(f.stems_per_ha_95.high, f.stems_per_ha) << "the hidden ground may hold stems";
  EXPECT_NEAR(f.expected_hidden_stems, 4 * 60.0 / (M_PI * 100 - 60.0), 1e-9);
  EXPECT_LT(f.basal_area_m2_per_ha_95.low, f.basal_area_m2_per_ha);
  EXPECT_GT(f.basal_area_m2_per_ha_95.high, f.basal_area_m2_per_ha);
  EXPECT_LT(f.qmd_cm_95.low, f.qmd_cm_95.high);
  // The draws are seeded: the same input gives the same intervals.
  const PlotFigures again = ComputePlotFigures(PlotFigureOptions(), trees, hidden);
  EXPECT_EQ(again.basal_area_m2_per_ha_95.low, f.basal_area_m2_per_ha_95.low);
}

// A detector that lists 96 % of the stems in view misses one now and then, visible or not: the
// plot may hold more stems than listed, however certain each listed one is, and the more listed,
// the likelier. The interval's top reaches above the count; with every stem in view listed it
// does not.
TEST(ComputePlotFigures, StemsInViewTheDetectorMissedWidenTheIntervalsUpward) {
  for (int n : {3, 8, 20}) {
    SCOPED_TRACE(::testing::Message() << n << " stems listed");
    std::vector<Stem> trees;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      trees.push_back(Listed(6 * std::cos(a), 6 * std::sin(a), 0.2 + 0.01 * i));
    }
    const Visibility all_seen{{}, 0.0, M_PI * 100};
    const PlotFigures f = ComputePlotFigures(PlotFigureOptions(), trees, all_seen);
    EXPECT_NEAR(f.stems_per_ha_95.low, f.stems_per_ha, 1e-9) << "certain stems are all there";
    EXPECT_GT(f.stems_per_ha_95.high, f.stems_per_ha);
    EXPECT_GT(f.basal_area_m2_per_ha_95.high, f.basal_area_m2_per_ha);
    PlotFigureOptions all_listed;
    all_listed.listed_share_in_view = 1.0;
    EXPECT_NEAR(ComputePlotFigures(all_listed, trees, all_seen).stems_per_ha_95.high,
                f.stems_per_ha, 1e-9);
  }
}

// The share of stems in view that are listed lies in (0, 1].
TEST(PlotFigureOptions, AListedShareOutsideZeroToOneIsRefused) {
  for (double share : {0.0, -0.5, 1.5}) {
    PlotFigureOptions o;
    o.listed_share_in_view = share;
    EXPECT_THROW(o.Check(), InputError) << share;
  }
  PlotFigureOptions o;
  o.listed_share_in_view = 1.0;
  EXPECT_NO_THROW(o.Check());
}

TEST(ComputePlotFigures, TheStandTableSplitsTheStemsByFiveCentimetreClass) {
  const std::vector<Stem> trees = {Listed(3, 0, 0.121), Listed(0, 5, 0.149), Listed(-6, -2, 0.25),
                                   Listed(2, 2, 0.312), Listed(11, 0, 0.50)};  // beyond the plot
  const PlotFigures f = ComputePlotFigures({}, trees, Visibility{{}, 0.0, M_PI * 100});
  const double area_ha = M_PI * 100 / 1e4;
  ASSERT_EQ(f.stand_table.size(), 5u);  // 10-15, 15-20 (empty), 20-25 (empty), 25-30, 30-35
  EXPECT_EQ(f.stand_table[0].from_cm, 10.0);
  EXPECT_EQ(f.stand_table[0].to_cm, 15.0);
  EXPECT_EQ(f.stand_table[0].stems, 2);
  EXPECT_EQ(f.stand_table[1].stems, 0);
  EXPECT_EQ(f.stand_table[3].stems, 1);
  EXPECT_EQ(f.stand_table[4].stems, 1);
  double per_ha = 0, basal = 0;
  for (const DbhClass& c : f.stand_table) {
    per_ha += c.stems_per_ha;
    basal += c.basal_area_m2_per_ha;
  }
  EXPECT_NEAR(per_ha, f.stems_per_ha, 1e-9);
  EXPECT_NEAR(basal, f.basal_area_m2_per_ha, 1e-9);
  EXPECT_NEAR(f.stand_table[0].stems_per_ha, 2 / area_ha, 1e-9);
  EXPECT_NEAR(f.plot_area_m2, M_PI * 100, 1e-9);
}

TEST(ComputePlotFigures, TheDominantDiameterIsTheQuadraticMeanOfTheHundredThickestAHectare) {
  // A 10-m plot is 0.0314 ha: its share of 100 stems a hectare is 3.14 stems.
  const std::vector<Stem> trees = {Listed(3, 0, 0.10), Listed(0, 5, 0.40), Listed(-6, -2, 0.20),
                                   Listed(2, -7, 0.30), Listed(-1, 4, 0.50)};
  const PlotFigures f = ComputePlotFigures({}, trees, Visibility{{}, 0.0, M_PI * 100});
  const double w = M_PI - 3.0;
  EXPECT_NEAR(f.dominant_diameter_cm, std::sqrt((2500 + 1600 + 900 + w * 400) / (3 + w)), 1e-9);
  EXPECT_NEAR(f.dominant_diameter_cm_95.low, f.dominant_diameter_cm, 1e-9);
  // Fewer stems than the share: all of them.
  const PlotFigures two = ComputePlotFigures({}, {Listed(3, 0, 0.30), Listed(0, 5, 0.40)},
                                             Visibility{{}, 0.0, M_PI * 100});
  EXPECT_NEAR(two.dominant_diameter_cm, std::sqrt((900 + 1600) / 2.0), 1e-9);
}

TEST(ComputePlotFigures, BorderlineStemsAreThoseWithinOneDbhOfTheEdgeCountedByTheirCentre) {
  const std::vector<Stem> trees = {Listed(9.8, 0, 0.30),   // inside, within a DBH: counted
                                   Listed(0, 10.2, 0.40),  // outside, within a DBH
                                   Listed(-9.5, 0, 0.20),  // inside, farther than its DBH
                                   Listed(3, 0, 0.30)};
  const PlotFigures f = ComputePlotFigures({}, trees, Visibility{{}, 0.0, M_PI * 100});
  EXPECT_EQ(f.borderline_stems, 2);
  EXPECT_EQ(f.borderline_counted, 1);
  EXPECT_EQ(f.stems, 3);
}

}  // namespace
}  // namespace stemmap::stems
