#include "stemmap/pipeline/process.h"

#include <gtest/gtest.h>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"

namespace stemmap::pipeline {
namespace {

TEST(PlotSummaryJson, WarnsWhenNoStemWasFound) {
  PlotFigures f;
  const nlohmann::json none = PlotSummaryJson(f, 0, 10.0, 7.0);
  ASSERT_EQ(none["warnings"].size(), 1u);
  EXPECT_NE(none["warnings"][0].get<std::string>().find("no stem of 7 cm"), std::string::npos);
  const nlohmann::json outside = PlotSummaryJson(f, 2, 10.0, 7.0);  // listed, none within 10 m
  ASSERT_EQ(outside["warnings"].size(), 1u);
  EXPECT_NE(outside["warnings"][0].get<std::string>().find("10.0-m plot radius"),
            std::string::npos);
  f.stems = 2;
  f.stems_per_ha = 63.7;
  const nlohmann::json some = PlotSummaryJson(f, 2, 10.0, 7.0);
  EXPECT_TRUE(some["warnings"].empty());
  EXPECT_EQ(some["stems"].get<int>(), 2);
  EXPECT_DOUBLE_EQ(some["stems_per_ha"].get<double>(), 63.7);
}

TEST(ProcessOptions, AOneSidedBoundBelowTheCloudIsRejected) {
  ProcessOptions o;
  EXPECT_NO_THROW(o.Check());
  o.one_sided_max_over_cloud = 0.9;  // would replace fits narrower than the cloud too
  EXPECT_THROW(o.Check(), InputError);
  o = ProcessOptions();
  o.one_sided_min_cloud_radius_m = -0.01;
  EXPECT_THROW(o.Check(), InputError);
  o = ProcessOptions();
  o.min_core_share = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  o = ProcessOptions();
  o.narrow_fit_share = -0.1;
  EXPECT_THROW(o.Check(), InputError);
}

TEST(ProcessOptions, TheLargerCloudsSettingsAreChecked) {
  ProcessOptions o;
  o.larger_cloud_part_gap_m = -0.1;
  EXPECT_EQ(CheckMessage(o),
            "the gap within which a larger cloud's part joins a stem must not be negative");
  o = ProcessOptions();
  o.larger_cloud_only_max_rms_px = -1;
  EXPECT_EQ(CheckMessage(o),
            "the rms a larger cloud's stem's silhouettes may keep must not be negative");
  o = ProcessOptions();
  o.wide_fit_scale = 0.9;
  EXPECT_EQ(CheckMessage(o),
            "the width over the cloud's that needs the bark to line up must be at least 1");
  o = ProcessOptions();
  o.wide_fit_min_bark_ncc = 1.5;
  EXPECT_EQ(CheckMessage(o), "the bark correlation a wide fit needs must lie in [-1, 1]");
  o = ProcessOptions();
  o.dense.short_baseline_max_depth_m = 2.0;  // inside the near pairs' own range
  EXPECT_EQ(CheckMessage(o),
            "the short-baseline depth limit must be 0 or beyond the near pairs' range");
  o.dense.short_baseline_max_depth_m = 0.0;  // none
  EXPECT_EQ(CheckMessage(o), "");
}

}  // namespace
}  // namespace stemmap::pipeline
