#include "stemmap/core/enum_names.h"

#include <gtest/gtest.h>

#include "stemmap/core/check_message.h"

namespace stemmap {
namespace {

enum class Shade { kLight, kDark };
constexpr EnumNames<Shade, 2> kShadeNames = {{{Shade::kLight, "light"}, {Shade::kDark, "dark"}}};

TEST(EnumNames, NamesEachValueAndReadsOnlyItsNames) {
  EXPECT_EQ(EnumName(kShadeNames, Shade::kDark), "dark");
  EXPECT_EQ(EnumChoices(kShadeNames), "light or dark");
  EXPECT_EQ(EnumFromName(kShadeNames, "dark", "shade"), Shade::kDark);
  EXPECT_EQ(EnumFromJson(kShadeNames, nlohmann::json("light"), "shade"), Shade::kLight);
  EXPECT_EQ(InputErrorMessage([] { (void)EnumFromName(kShadeNames, "Dark", "shade"); }),
            "shade 'Dark' is not light or dark");
  EXPECT_EQ(InputErrorMessage([] { (void)EnumFromJson(kShadeNames, nlohmann::json(1), "shade"); }),
            "shade must be one of light or dark, not 1");
}

}  // namespace
}  // namespace stemmap
