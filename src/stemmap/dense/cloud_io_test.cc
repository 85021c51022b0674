#include "stemmap/dense/cloud_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::dense {
namespace {

namespace fs = std::filesystem;

fs::path TestDir() {
  const fs::path d = fs::temp_directory_path() / ("stemmap_cloud_io_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

std::vector<CloudPoint> SomePoints() {
  return {{{1.5f, -2.25f, 0.75f}, {0.5f, 0.8f, 1.3f}, cv::Vec3b(10, 20, 30), 4, -1, true},
          {{-7.0f, 3.0f, 1.37f}, {-0.9f, 0.1f, 1.31f}, cv::Vec3b(200, 100, 0), 117, 1, false},
          {{0.0f, 9.5f, -0.2f}, {0.0f, 1.0f, 1.3f}, cv::Vec3b(0, 0, 255), 0, 0, true}};
}

TEST(CloudPly, EveryFieldRoundTrips) {
  const fs::path path = TestDir() / "cloud.ply";
  WriteCloudPly(path, SomePoints());
  const std::vector<CloudPoint> written = SomePoints(), back = ReadCloudPly(path);
  ASSERT_EQ(back.size(), written.size());
  for (size_t i = 0; i < back.size(); ++i) {
    const CloudPoint &a = written[i], &b = back[i];
    EXPECT_EQ(a.world, b.world) << i;
    EXPECT_EQ(a.origin, b.origin) << i;
    EXPECT_EQ(a.bgr, b.bgr) << i;
    EXPECT_EQ(a.keyframe, b.keyframe) << i;
    EXPECT_EQ(a.trunk, b.trunk) << i;
    EXPECT_EQ(a.at_view_bottom, b.at_view_bottom) << i;
  }
  WriteCloudPly(path, {});
  EXPECT_TRUE(ReadCloudPly(path).empty());
  fs::remove_all(TestDir());
}

// A cloud written before points kept their view's bottom edge reads with none marked.
TEST(CloudPly, ACloudWithoutViewBottomMarksReads) {
  const fs::path path = TestDir() / "cloud.ply";
  WriteCloudPly(path, SomePoints());
  std::string old = ReadFileToString(path);
  const std::string mark = "property uchar view_bottom\n";
  old.erase(old.find(mark), mark.size());
  const size_t header = old.find("end_header\n") + 11;
  for (size_t i = 0; i < SomePoints().size(); ++i) old.erase(header + 32 * (i + 1), 1);
  WriteFileAtomic(path, old);
  const std::vector<CloudPoint> written = SomePoints(), back = ReadCloudPly(path);
  ASSERT_EQ(back.size(), written.size());
  for (size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].world, written[i].world) << i;
    EXPECT_EQ(back[i].keyframe, written[i].keyframe) << i;
    EXPECT_EQ(back[i].trunk, written[i].trunk) << i;
    EXPECT_FALSE(back[i].at_view_bottom) << i;
  }
  fs::remove_all(TestDir());
}

TEST(CloudPly, OtherOrDamagedFilesAreRefused) {
  const fs::path path = TestDir() / "cloud.ply";
  WriteCloudPly(path, SomePoints());
  const std::string good = ReadFileToString(path);
  auto refused = [&](const std::string& content) {
    WriteFileAtomic(path, content);
    try {
      ReadCloudPly(path);
    } catch (const InputError& e) {
      return std::string(e.what()).find(path.string()) != std::string::npos;
    }
    return false;
  };
  EXPECT_TRUE(refused(""));
  EXPECT_TRUE(refused(good.substr(0, good.size() - 1))) << "cut short";
  EXPECT_TRUE(refused(good + "x")) << "bytes beyond the points";
  std::string ascii = good;
  ascii.replace(ascii.find("binary_little_endian"), 20, "ascii");
  EXPECT_TRUE(refused(ascii));
  std::string count = good;
  count.replace(count.find("vertex 3"), 8, "vertex 9999999999999");
  EXPECT_TRUE(refused(count)) << "a count beyond any file";
  std::string nan = good;
  const float bad = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + nan.find("end_header\n") + 11, &bad, 4);
  EXPECT_TRUE(refused(nan));
  std::string mark = good;
  mark[mark.find("end_header\n") + 11 + 32] = 7;
  EXPECT_TRUE(refused(mark)) << "a view-bottom mark other than 0 or 1";
  fs::remove_all(TestDir());
}

}  // namespace
}  // namespace stemmap::dense
