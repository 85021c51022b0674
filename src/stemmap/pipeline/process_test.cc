#include "stemmap/pipeline/process.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::pipeline {
namespace {

namespace fs = std::filesystem;

TEST(PlotSummaryJson, WarnsWhenNoStemWasFound) {
  stems::PlotFigures f;
  const stems::Visibility v;
  const nlohmann::json none = PlotSummaryJson(f, v, 0, 10.0, 7.0);
  ASSERT_EQ(none["warnings"].size(), 1u);
  EXPECT_NE(none["warnings"][0].get<std::string>().find("no stem of 7 cm"), std::string::npos);
  const nlohmann::json outside = PlotSummaryJson(f, v, 2, 10.0, 7.0);  // listed, none within 10 m
  ASSERT_EQ(outside["warnings"].size(), 1u);
  EXPECT_NE(outside["warnings"][0].get<std::string>().find("10.0-m plot radius"),
            std::string::npos);
  f.stems = 2;
  f.stems_per_ha = 63.7;
  const nlohmann::json some = PlotSummaryJson(f, v, 2, 10.0, 7.0);
  EXPECT_TRUE(some["warnings"].empty());
  EXPECT_EQ(some["stems"].get<int>(), 2);
  EXPECT_DOUBLE_EQ(some["stems_per_ha"].get<double>(), 63.7);
}

TEST(ProcessOptions, EachStagesOptionsAreChecked) {
  ProcessOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.measure.wide_fit_scale = 0.9;
  EXPECT_EQ(CheckMessage(o),
            "the width over the cloud's that needs the bark to line up must be at least 1");
  o = ProcessOptions();
  o.plot_radius_m = 0;
  EXPECT_EQ(CheckMessage(o), "--plot-radius must be positive");
  o = ProcessOptions();
  o.dense.short_baseline_max_depth_m = 2.0;  // inside the near pairs' own range
  EXPECT_EQ(CheckMessage(o),
            "the short-baseline depth limit must be 0 or beyond the near pairs' range");
  o.dense.short_baseline_max_depth_m = 0.0;  // none
  EXPECT_EQ(CheckMessage(o), "");
}

fs::path OptionsDir() {
  const fs::path d =
      fs::temp_directory_path() / ("stemmap_process_options_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// Every option, at every level, is saved and read back as it was.
TEST(ProcessOptions, EveryOptionRoundTripsThroughItsFile) {
  ProcessOptions o;
  o.plot_radius_m = 12.5;
  o.track.frontend.track_fps = 7.5;
  o.track.bundle.sigma_mount_deg = 0.9;
  o.track.calibration = "/phones/a.yaml";
  o.dense.stereo.block_size = 7;
  o.measure.stems.dbh_method = stems::DbhMethod::kSlice;
  o.measure.tangent.wide_start_scales = {1.4};
  o.measure.bark_depth.min_pairs = 4;
  o.mask.mean = {0.5, 0.5, 0.5};
  o.from_track = "/runs/a";
  WriteJsonAtomic(OptionsDir() / "all.json", o);
  const ProcessOptions back = ReadOptionsJson<ProcessOptions>(OptionsDir() / "all.json");
  EXPECT_EQ(nlohmann::json(back), nlohmann::json(o));
  EXPECT_EQ(back.track.calibration, o.track.calibration);
  EXPECT_EQ(back.measure.tangent.wide_start_scales, o.measure.tangent.wide_start_scales);
}

TEST(ProcessOptions, AFileMayGiveSomeOptionsAndFlagsOverrideIt) {
  WriteFileAtomic(OptionsDir() / "some.json",
                  R"({"plot_radius_m": 15, "measure": {"tangent": {"min_rays": 5}, "stems": {}}})");
  const ProcessOptions from_file = ReadOptionsJson<ProcessOptions>(OptionsDir() / "some.json");
  EXPECT_EQ(from_file.plot_radius_m, 15.0);
  EXPECT_EQ(from_file.measure.tangent.min_rays, 5);
  EXPECT_EQ(from_file.measure.min_dbh_cm, ProcessOptions{}.measure.min_dbh_cm)
      << "a missing key keeps its default";
  ProcessOptions flags;
  flags.measure.min_dbh_cm = 10.0;
  flags.track.arm_radius_m = 0.8;
  const ProcessOptions merged = OverlayOptions(from_file, flags);
  EXPECT_EQ(merged.plot_radius_m, 15.0);
  EXPECT_EQ(merged.measure.tangent.min_rays, 5);
  EXPECT_EQ(merged.measure.min_dbh_cm, 10.0);
  EXPECT_EQ(merged.track.arm_radius_m, 0.8);
}

TEST(ProcessOptions, AnOptionsFileOfTheWrongShapeIsAnInputError) {
  for (const char* text :
       {R"([1, 2])", R"({"plot_radius_m": "ten"})",
        R"({"measure": {"tangent": {"wide_start_scales": 2}}})", R"({"track": 3})", "{"}) {
    WriteFileAtomic(OptionsDir() / "bad.json", text);
    EXPECT_THROW(ReadOptionsJson<ProcessOptions>(OptionsDir() / "bad.json"), InputError) << text;
  }
}

// A key that no option has, misspelt or at the wrong level (a `track` file's keys inside "track"
// where `track` wants them at the top), is refused by name rather than dropped for the default.
TEST(ProcessOptions, AKeyThatIsNoOptionIsRefusedByName) {
  for (const auto& [text, name] :
       {std::pair<const char*, const char*>{R"({"plot_radius": 15})", "'plot_radius'"},
        {R"({"track": {"bundle": {"sigma_mount": 0.2}}})", "'track.bundle.sigma_mount'"},
        {R"({"measure": {"tangent": {"min_rays": 5}}, "trak": {}})", "'trak'"}}) {
    WriteFileAtomic(OptionsDir() / "typo.json", text);
    try {
      ReadOptionsJson<ProcessOptions>(OptionsDir() / "typo.json");
      ADD_FAILURE() << text << " was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  WriteFileAtomic(OptionsDir() / "nested.json",
                  R"({"track": {"bundle": {"sigma_mount_deg": 0.2}}})");
  EXPECT_EQ(
      ReadOptionsJson<ProcessOptions>(OptionsDir() / "nested.json").track.bundle.sigma_mount_deg,
      0.2);
  WriteFileAtomic(OptionsDir() / "track.json", R"({"track": {"focal": "fixed"}})");
  EXPECT_THROW(ReadOptionsJson<track::TrackOptions>(OptionsDir() / "track.json"), InputError);
}

}  // namespace
}  // namespace stemmap::pipeline
