#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/video/video_reader.h"
#include "stemmap/video/video_writer.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

fs::path TestDir() {
  const fs::path d =
      fs::temp_directory_path() / ("stemmap_video_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

cv::Mat TestFrame(int w, int h, int i) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 90, 60));
  cv::rectangle(img, cv::Rect(10 + 4 * i, 20, 30, h - 40), cv::Scalar(200, 180, 160), cv::FILLED);
  return img;
}

TEST(Video, WriteThenReadRoundTrip) {
  const fs::path path = TestDir() / "clip.mp4";
  VideoWriterOptions wo;
  wo.width = 160;
  wo.height = 96;
  wo.fps = 10;
  wo.bitrate_mbps = 1.0;
  VideoWriter writer(path, wo);
  for (int i = 0; i < 20; ++i) writer.Write(TestFrame(wo.width, wo.height, i));
  EXPECT_FALSE(fs::exists(path)) << "the file must appear only when complete";
  writer.Close();
  ASSERT_TRUE(fs::exists(path));

  VideoReaderOptions ro;
  ro.max_long_side_px = 80;
  ro.full_gray = true;
  VideoReader reader(path, ro);
  EXPECT_EQ(reader.info().width, 80);
  EXPECT_EQ(reader.info().height, 48);
  EXPECT_EQ(reader.info().full_width, 160);
  EXPECT_EQ(reader.info().full_height, 96);
  EXPECT_NEAR(reader.info().fps, 10.0, 1e-6);
  int n = 0;
  double last_t = -1;
  while (auto f = reader.Next()) {
    EXPECT_EQ(f->bgr.cols, 80);
    EXPECT_GT(f->t_s, last_t);
    last_t = f->t_s;
    if (n == 5) {
      // The bright bar sits where it was drawn (x = 30..60 at full size → 15..30 at half size).
      EXPECT_GT(f->bgr.at<cv::Vec3b>(24, 22)[0], 150);
      EXPECT_LT(f->bgr.at<cv::Vec3b>(24, 60)[0], 80);
      // The luma keeps the stored size: the bar at x = 30..60.
      ASSERT_EQ(f->gray_full.size(), cv::Size(160, 96));
      EXPECT_GT(f->gray_full.at<uchar>(48, 45), 150);
      EXPECT_LT(f->gray_full.at<uchar>(48, 120), 100);
    }
    ++n;
  }
  EXPECT_EQ(n, 20);
  EXPECT_NEAR(last_t, 1.9, 1e-6);
}

TEST(Video, PrefetchingGivesTheSameFramesInTheSameOrder) {
  const fs::path path = TestDir() / "prefetch.mp4";
  VideoWriterOptions wo;
  wo.width = 160;
  wo.height = 96;
  wo.fps = 10;
  VideoWriter writer(path, wo);
  for (int i = 0; i < 25; ++i) writer.Write(TestFrame(wo.width, wo.height, i));
  writer.Close();

  VideoReader direct(path);
  VideoReaderOptions ro;
  ro.prefetch_frames = 3;
  VideoReader ahead(path, ro);
  int n = 0;
  while (auto a = direct.Next()) {
    const auto b = ahead.Next();
    ASSERT_TRUE(b.has_value()) << "frame " << n;
    EXPECT_EQ(b->index, a->index);
    EXPECT_DOUBLE_EQ(b->t_s, a->t_s);
    EXPECT_EQ(cv::norm(a->bgr, b->bgr, cv::NORM_INF), 0.0) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, 25);
  EXPECT_FALSE(ahead.Next().has_value());
  EXPECT_FALSE(ahead.Next().has_value()) << "the end stays the end";
  // A reader dropped mid-stream stops its background thread.
  VideoReader abandoned(path, ro);
  ASSERT_TRUE(abandoned.Next().has_value());
}

TEST(Video, MissingAndCorruptFilesAreInputErrors) {
  EXPECT_THROW(VideoReader(TestDir() / "nope.mp4"), InputError);
  const fs::path junk = TestDir() / "junk.mp4";
  WriteFileAtomic(junk, std::string(4096, 'x'));
  EXPECT_THROW(VideoReader{junk}, InputError);
}

TEST(Video, WriterRejectsOddSize) {
  VideoWriterOptions wo;
  wo.width = 161;
  EXPECT_THROW(wo.Check(), InputError);
}

}  // namespace
}  // namespace stemmap
