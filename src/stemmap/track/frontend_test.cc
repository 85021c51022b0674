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

}  // namespace
}  // namespace stemmap::track
