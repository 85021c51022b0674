#include "stemmap/track/track.h"

#include <gtest/gtest.h>

#include "stemmap/core/error.h"

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

}  // namespace
}  // namespace stemmap::track
