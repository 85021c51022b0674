#include "stemmap/track/track.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/track/track_io.h"

namespace stemmap::track {
namespace {

// A calibrated run: a turn looks like a turn plus the arm's parallax when the video's focal
// length is the calibration's; a stabilising crop (10-25 % longer) or a shorter lens shows as a
// turn that looks that much longer or shorter, and only then is there a warning.
TEST(CalibrationFocalWarning, WarnsOnlyWhenTheTurnSaysTheFocalLengthIsAnother) {
  TrackOptions o;
  o.calibration = "phone.yaml";
  for (double factor : {0.97, 1.0, 1.02, 1.05}) {
    EXPECT_EQ(CalibrationFocalWarning(o, factor), "") << factor;
  }
  for (double crop : {1.1, 1.15, 1.25}) {
    const std::string w = CalibrationFocalWarning(o, 1.02 * crop);
    EXPECT_NE(w.find("stabilisation"), std::string::npos) << crop;
    EXPECT_NE(w.find("longer"), std::string::npos) << w;
  }
  EXPECT_NE(CalibrationFocalWarning(o, 0.9).find("shorter"), std::string::npos);
  // Without a calibration nothing says what it should be.
  o = TrackOptions();
  EXPECT_EQ(CalibrationFocalWarning(o, 1.15), "");
  o.calibration_focal_tolerance = 0;
  EXPECT_THROW(o.Check(), InputError);
}

TEST(TrackOptions, BreathingNeedsAStrayAndAtLeastOneKeyframe) {
  TrackOptions o;
  o.breathing_min_pct = -0.1;
  EXPECT_THROW(o.Check(), InputError);
  o = TrackOptions();
  o.breathing_min_keyframes = 0;
  try {
    o.Check();
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("focus breathing"), std::string::npos) << e.what();
  }
}

// The focal mode is saved and read back by name; an options file with a mode that does not exist
// is refused, naming the file and the choices.
TEST(TrackOptions, TheFocalModeReadsBackByNameAndNoOtherName) {
  TrackOptions o;
  o.focal = FocalMode::kFixed;
  const nlohmann::json j = o;
  EXPECT_EQ(j.at("focal"), "fixed");
  EXPECT_EQ(j.get<TrackOptions>().focal, FocalMode::kFixed);
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("stemmap_focal_mode_" + std::to_string(getpid()) + ".json");
  WriteFileAtomic(path, R"({"focal": "sharp"})");
  const std::string what = InputErrorMessage([&] { (void)ReadOptionsJson<TrackOptions>(path); });
  EXPECT_NE(what.find(path.filename().string()), std::string::npos) << what;
  EXPECT_NE(what.find("focal mode 'sharp' is not auto, fixed or refine"), std::string::npos)
      << what;
  std::filesystem::remove(path);
}

// A track folder whose per-keyframe focal lengths do not match its keyframes is refused, naming
// the file, rather than redrawing some keyframes and not others.
TEST(ReadTrackFolder, RefusesFocalScalesThatDoNotMatchTheKeyframes) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("stemmap_track_focal_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::vector<StampedPose> keyframes;
  for (int k = 0; k < 4; ++k) keyframes.push_back({0.5 * k, Rigid3d{}});
  WriteTumTrajectory(dir / "keyframes.tum", keyframes);
  nlohmann::json track = {{"camera", PinholeCamera::FromHfov(640, 360, 67.0)}};
  track["keyframe_focal_scale"] = {1.0, 1.001, 0.999};
  WriteJsonAtomic(dir / "summary.json", {{"track", track}});
  try {
    ReadTrackFolder(dir);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("3 keyframe focal scales for 4 keyframes"), std::string::npos) << what;
    EXPECT_NE(what.find("summary.json"), std::string::npos) << what;
  }
  track["keyframe_focal_scale"] = "not a list";
  WriteJsonAtomic(dir / "summary.json", {{"track", track}});
  EXPECT_THROW(ReadTrackFolder(dir), InputError);
  track["keyframe_focal_scale"] = {1.0, 1.001, 0.999, 1.0};
  WriteJsonAtomic(dir / "summary.json", {{"track", track}});
  EXPECT_EQ(ReadTrackFolder(dir).keyframe_focal_scale.size(), 4u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace stemmap::track
