#include "stemmap/stems/uncertainty.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stemmap/core/check_message.h"

namespace stemmap::stems {
namespace {

// A 30-cm stem its silhouettes fit to 2 mm, its cloud's width agreeing.
Stem Fitted() {
  Stem s;
  s.centre_xy = {6.0, 0.0};
  s.dbh_m = s.dbh_tangent_m = 0.30;
  s.dbh_tangent_sd_m = 0.002;
  s.dbh_slice_m = 0.30;
  return s;
}

TEST(DbhSd, GrowsWithWhatTheWidthCannotCheck) {
  const UncertaintyOptions o;
  const double px_m = 6.0 / 1500.0;
  const double clean = DbhSd(o, Fitted(), px_m);
  EXPECT_GT(clean, 0.002) << "more than the fit's own spread";
  EXPECT_LT(clean, 0.01);
  EXPECT_GT(DbhSd(o, Fitted(), 2 * px_m), clean) << "a pixel covers more on a far stem";
  Stem gap = Fitted();
  gap.dbh_slice_m = 0.22;  // the cloud saw much less of it
  EXPECT_NEAR(DbhSd(o, gap, px_m), std::hypot(clean, o.estimator_gap_share * 0.08), 1e-9);
  // Each flag adds its share of the DBH.
  UncertaintyOptions shares = o;
  shares.one_sided_share = shares.occluded_share = shares.depth_smeared_share =
      shares.few_views_share = 0.1;
  for (StemFlag f :
       {StemFlag::kOneSided, StemFlag::kOccluded, StemFlag::kDepthSmeared, StemFlag::kFewViews}) {
    Stem flagged = Fitted();
    flagged.flags.Set(f);
    EXPECT_NEAR(DbhSd(shares, flagged, px_m), std::hypot(clean, 0.1 * 0.30), 1e-9) << FlagName(f);
  }
  // The cloud's width alone: its own spread and a share of the DBH.
  Stem cloud = Fitted();
  cloud.dbh_tangent_m = 0;
  cloud.dbh_sd_m = 0.01;
  cloud.flags.Set(StemFlag::kNoSilhouette);
  EXPECT_GT(DbhSd(o, cloud, px_m), o.no_silhouette_share * 0.30);
}

// A stem a nearer one hides one side of, its DBH the stand's between the width seen and the
// widest hidden: two SD reach the farther of the two.
TEST(DbhSd, AWidthFromTheStandReachesItsBounds) {
  const UncertaintyOptions o;
  Stem s = Fitted();
  s.dbh_seen_m = 0.12;
  s.dbh_hidden_max_m = 0.60;
  s.flags.Set(StemFlag::kWidthFromStand);
  const double sd = DbhSd(o, s, 0.004);
  EXPECT_GE(2 * sd, 0.60 - 0.30);
  EXPECT_LT(2 * sd, 0.60 - 0.30 + 0.03);
}

TEST(DetectionConfidence, FollowsWhatListedTheStem) {
  const UncertaintyOptions o;
  Stem s = Fitted();
  EXPECT_EQ(DetectionConfidence(o, s), o.confidence_two_sided);
  s.flags.Set(StemFlag::kOneSided);
  EXPECT_EQ(DetectionConfidence(o, s), o.confidence_one_sided);
  s.flags.Set(StemFlag::kNoSilhouette);
  EXPECT_EQ(DetectionConfidence(o, s), o.confidence_cloud_only);
  s.flags.Set(StemFlag::kSilhouetteOnly);
  EXPECT_EQ(DetectionConfidence(o, s), o.confidence_silhouette_only);
}

TEST(UncertaintyOptions, AreChecked) {
  UncertaintyOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.section_share = -0.1;
  EXPECT_EQ(CheckMessage(o), "the DBH uncertainty's terms must not be negative");
  o = UncertaintyOptions();
  o.confidence_cloud_only = 1.2;
  EXPECT_EQ(CheckMessage(o), "a detection confidence must lie in [0, 1]");
}

}  // namespace
}  // namespace stemmap::stems
