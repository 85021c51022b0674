#include "stemmap/track/frontend.h"

#include <gtest/gtest.h>

#include <string>

#include "stemmap/core/error.h"

namespace stemmap::track {
namespace {

TEST(Frontend, OptionsRejectKltWindowsTooSmall) {
  EXPECT_NO_THROW(FrontendOptions{}.Check());
  FrontendOptions tiny;
  tiny.lk_refine_window_px = 1;
  try {
    tiny.Check();
    FAIL() << "a 1-px refinement window was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("KLT windows"), std::string::npos) << e.what();
  }
  FrontendOptions levels;
  levels.lk_refine_levels = -1;
  EXPECT_THROW(levels.Check(), InputError);
}

// A rolling shutter: the top row is read half a readout before the frame's time, the bottom row
// half after, the middle row at it; a point moves back along its velocity by that much.
TEST(Frontend, AtFrameTimeUndoesEachRowsDelay) {
  const Eigen::Vector2d v(-300.0, 20.0);  // px/s: a turning camera
  const double readout_s = 0.025;
  const int rows = 541;
  EXPECT_EQ(AtFrameTime({100.0, 270.0}, v, readout_s, rows), Eigen::Vector2d(100.0, 270.0));
  const Eigen::Vector2d top = AtFrameTime({100.0, 0.0}, v, readout_s, rows);
  EXPECT_NEAR(top.x(), 100.0 - 0.5 * readout_s * 300.0, 1e-12);
  EXPECT_NEAR(top.y(), 0.0 + 0.5 * readout_s * 20.0, 1e-12);
  const Eigen::Vector2d bottom = AtFrameTime({100.0, 540.0}, v, readout_s, rows);
  EXPECT_NEAR(bottom.x(), 100.0 + 0.5 * readout_s * 300.0, 1e-12);
  // A global shutter moves nothing.
  EXPECT_EQ(AtFrameTime({100.0, 0.0}, v, 0.0, rows), Eigen::Vector2d(100.0, 0.0));
  FrontendOptions o;
  o.readout_ms = -1;
  EXPECT_THROW(o.Check(), InputError);
  o.readout_ms = 150;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::track
