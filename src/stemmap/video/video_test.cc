#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

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

// The tests' clips: 160x96 at 10 fps.
VideoWriterOptions ClipOptions() {
  VideoWriterOptions wo;
  wo.width = 160;
  wo.height = 96;
  wo.fps = 10;
  wo.bitrate_mbps = 1.0;
  return wo;
}

TEST(Video, WriteThenReadRoundTrip) {
  const fs::path path = TestDir() / "clip.mp4";
  const VideoWriterOptions wo = ClipOptions();
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

TEST(Video, UnwantedFramesComeWithTheirTimesButNoImages) {
  const fs::path path = TestDir() / "wanted.mp4";
  const VideoWriterOptions wo = ClipOptions();
  VideoWriter writer(path, wo);
  for (int i = 0; i < 12; ++i) writer.Write(TestFrame(wo.width, wo.height, i));
  writer.Close();

  VideoReaderOptions all_options;
  all_options.full_gray = true;
  VideoReader all(path, all_options);
  VideoReaderOptions some_options = all_options;
  some_options.prefetch_frames = 2;
  some_options.wanted = [](const VideoInfo& info, int64_t index, double) {
    return index % FrameStride(info.fps, 5.0) == 0;  // 10 fps sampled at 5: every second frame
  };
  VideoReader some(path, some_options);
  int n = 0;
  while (auto a = all.Next()) {
    const auto b = some.Next();
    ASSERT_TRUE(b.has_value()) << "frame " << n;
    EXPECT_EQ(b->index, a->index);
    EXPECT_DOUBLE_EQ(b->t_s, a->t_s);
    EXPECT_EQ(b->converted, n % 2 == 0) << "frame " << n;
    if (n % 2 == 0) {
      EXPECT_EQ(cv::norm(a->bgr, b->bgr, cv::NORM_INF), 0.0) << "frame " << n;
      EXPECT_EQ(cv::norm(a->gray_full, b->gray_full, cv::NORM_INF), 0.0) << "frame " << n;
    } else {
      EXPECT_TRUE(b->bgr.empty() && b->gray_full.empty()) << "frame " << n;
    }
    ++n;
  }
  EXPECT_EQ(n, 12);
  EXPECT_EQ(FrameStride(30.0, 15.0), 2);
  EXPECT_EQ(FrameStride(10.0, 15.0), 1) << "never below one";
  EXPECT_EQ(FrameStride(0.0, 15.0), 2) << "an unknown rate counts as 30 fps";
}

TEST(Video, MissingAndCorruptFilesAreInputErrors) {
  EXPECT_THROW(VideoReader(TestDir() / "nope.mp4"), InputError);
  const fs::path junk = TestDir() / "junk.mp4";
  WriteFileAtomic(junk, std::string(4096, 'x'));
  EXPECT_THROW(VideoReader{junk}, InputError);
}

// Phones store portrait video as landscape frames plus a display rotation, and many record HEVC
// in .mov; FFmpeg's command-line tool makes such files from ours.
bool HaveFfmpegTool() { return std::system("ffmpeg -hide_banner -version > /dev/null 2>&1") == 0; }

void RunFfmpeg(const fs::path& in, const std::string& args, const fs::path& out) {
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -y -i '" + in.string() + "' " +
                          args + " '" + out.string() + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

// A clip of `frames` frames, TestFrame's unless `frame` draws them.
fs::path WriteClip(const fs::path& path, int frames,
                   const std::function<cv::Mat(int)>& frame = nullptr) {
  const VideoWriterOptions wo = ClipOptions();
  VideoWriter writer(path, wo);
  for (int i = 0; i < frames; ++i) {
    writer.Write(frame ? frame(i) : TestFrame(wo.width, wo.height, i));
  }
  writer.Close();
  return path;
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  return cv::norm(a, b, cv::NORM_L1) / static_cast<double>(a.total() * a.channels());
}

// The recording's time as a phone tags it; nothing when the file has no tag.
TEST(Video, ReadsWhenTheRecordingWasMade) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path clip = WriteClip(TestDir() / "untagged.mp4", 3);
  EXPECT_EQ(VideoReader(clip).info().creation_time, "");
  const fs::path tagged = TestDir() / "tagged.mp4";
  RunFfmpeg(clip, "-c copy -metadata creation_time=2026-05-04T10:11:12.000000Z", tagged);
  EXPECT_EQ(VideoReader(tagged).info().creation_time, "2026-05-04T10:11:12.000000Z");
}

// The reader shows a rotated file as FFmpeg's own player does (its tool rotates on decode).
TEST(Video, DisplayRotationTurnsFramesAsPlayersDo) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path clip = WriteClip(TestDir() / "landscape.mp4", 10);
  for (const int tag : {90, 180, 270}) {
    const fs::path turned = TestDir() / ("turned" + std::to_string(tag) + ".mp4");
    RunFfmpeg(clip, "-c copy -metadata:s:v:0 rotate=" + std::to_string(tag), turned);
    const fs::path raw = TestDir() / ("turned" + std::to_string(tag) + ".bgr");
    RunFfmpeg(turned, "-f rawvideo -pix_fmt bgr24", raw);
    const std::string shown = ReadFileToString(raw);
    VideoReaderOptions ro;
    ro.full_gray = true;
    VideoReader reader(turned, ro);
    const bool portrait = tag != 180;
    EXPECT_EQ(reader.info().rotation_deg % 180, portrait ? 90 : 0) << tag;
    ASSERT_EQ(reader.info().width, portrait ? 96 : 160);
    ASSERT_EQ(reader.info().height, portrait ? 160 : 96);
    EXPECT_EQ(reader.info().full_height, portrait ? 160 : 96);
    const size_t frame_bytes = 96 * 160 * 3;
    ASSERT_EQ(shown.size(), 10 * frame_bytes);
    int n = 0;
    while (auto f = reader.Next()) {
      const cv::Mat expected(reader.info().height, reader.info().width, CV_8UC3,
                             const_cast<char*>(shown.data() + n * frame_bytes));
      EXPECT_LT(MeanAbsDiff(f->bgr, expected), 2.0) << "rotate=" << tag << " frame " << n;
      EXPECT_EQ(f->gray_full.size(), expected.size());
      ++n;
    }
    EXPECT_EQ(n, 10);
  }
}

TEST(Video, HevcInMovDecodes) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path clip = WriteClip(TestDir() / "h264.mp4", 12);
  const fs::path hevc = TestDir() / "hevc.mov";
  RunFfmpeg(clip, "-c:v libx265 -x265-params log-level=none -pix_fmt yuv420p", hevc);
  VideoReader reader(hevc);
  EXPECT_EQ(reader.info().codec, "hevc");
  int n = 0;
  double last_t = -1;
  while (auto f = reader.Next()) {
    EXPECT_GT(f->t_s, last_t);
    last_t = f->t_s;
    EXPECT_LT(MeanAbsDiff(f->bgr, TestFrame(160, 96, n)), 6.0) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, 12);
  EXPECT_NEAR(last_t, 1.1, 1e-6);
}

// A copy cut short (a card pulled mid-write): with the index at the end nothing can be read and
// the file is refused; with the index first (as some phones write) the frames before the cut are
// read and the rest is lost without a crash.
TEST(Video, TruncatedFilesAreRefusedOrReadUpToTheCut) {
  // Textured frames, so that the cut falls among the frames rather than in the header.
  cv::RNG rng(7);
  const fs::path clip = WriteClip(TestDir() / "whole.mp4", 30, [&rng](int) {
    cv::Mat img(96, 160, CV_8UC3);
    rng.fill(img, cv::RNG::UNIFORM, 0, 255);
    return img;
  });
  auto cut = [](const fs::path& from, double keep) {
    const std::string bytes = ReadFileToString(from);
    const fs::path to = TestDir() / (from.stem().string() + "_cut.mp4");
    WriteFileAtomic(to, bytes.substr(0, static_cast<size_t>(keep * bytes.size())));
    return to;
  };
  EXPECT_THROW(VideoReader{cut(clip, 0.6)}, InputError);
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path indexed_first = TestDir() / "faststart.mp4";
  RunFfmpeg(clip, "-c copy -movflags +faststart", indexed_first);
  VideoReader reader(cut(indexed_first, 0.6));
  int n = 0;
  while (reader.Next()) ++n;
  EXPECT_GT(n, 5);
  EXPECT_LT(n, 30);
}

// A test-pattern clip of `frames` frames made by FFmpeg's tool at w x h (any size, odd too),
// encoded with `codec_args`, and the BGR frames FFmpeg itself decodes from it.
struct PatternClip {
  fs::path path;
  std::vector<cv::Mat> shown;  // FFmpeg's decoding, BGR, display orientation
};

PatternClip MakePatternClip(const std::string& name, int w, int h, int frames,
                            const std::string& codec_args) {
  PatternClip clip;
  clip.path = TestDir() / name;
  const std::string make = fmt::format(
      "ffmpeg -hide_banner -loglevel error -y -f lavfi -i testsrc2=size=320x180:rate=10 -frames:v "
      "{} -vf scale={}:{} {} '{}'",
      frames, w, h, codec_args, clip.path.string());
  EXPECT_EQ(std::system(make.c_str()), 0) << make;
  const fs::path raw = TestDir() / (name + ".bgr");
  RunFfmpeg(clip.path, "-f rawvideo -pix_fmt bgr24", raw);
  const std::string bytes = ReadFileToString(raw);
  const size_t frame_bytes = static_cast<size_t>(w) * h * 3;
  EXPECT_EQ(bytes.size(), frames * frame_bytes) << name;
  for (size_t at = 0; at + frame_bytes <= bytes.size(); at += frame_bytes) {
    clip.shown.push_back(cv::Mat(h, w, CV_8UC3, const_cast<char*>(bytes.data() + at)).clone());
  }
  return clip;
}

// Each decoded frame matches FFmpeg's own decoding: at full size, as luma, and scaled down.
void ExpectDecodedAsShown(const PatternClip& clip, int max_long_side_px) {
  SCOPED_TRACE(clip.path.filename().string());
  ASSERT_FALSE(clip.shown.empty());
  const cv::Size full = clip.shown[0].size();
  for (const bool full_size : {true, false}) {
    VideoReaderOptions ro;
    ro.full_gray = true;
    ro.max_long_side_px = full_size ? 0 : max_long_side_px;
    VideoReader reader(clip.path, ro);
    EXPECT_EQ(reader.info().full_width, full.width);
    EXPECT_EQ(reader.info().full_height, full.height);
    size_t n = 0;
    while (auto f = reader.Next()) {
      ASSERT_LT(n, clip.shown.size());
      ASSERT_TRUE(f->bgr.isContinuous());
      // Not a view into a larger buffer: OpenCV's filters would read past its edges.
      cv::Size whole;
      cv::Point offset;
      f->bgr.locateROI(whole, offset);
      EXPECT_EQ(whole, f->bgr.size());
      f->gray_full.locateROI(whole, offset);
      EXPECT_EQ(whole, f->gray_full.size());
      ASSERT_EQ(f->gray_full.size(), full);
      cv::Mat expected_gray;
      cv::cvtColor(clip.shown[n], expected_gray, cv::COLOR_BGR2GRAY);
      EXPECT_LT(MeanAbsDiff(f->gray_full, expected_gray), 2.0) << "frame " << n;
      cv::Mat expected = clip.shown[n];
      if (!full_size) {
        EXPECT_EQ(std::max(f->bgr.cols, f->bgr.rows),
                  std::min(max_long_side_px, std::max(full.width, full.height)));
        cv::resize(clip.shown[n], expected, f->bgr.size(), 0, 0, cv::INTER_AREA);
      }
      ASSERT_EQ(f->bgr.size(), expected.size());
      // Scaling by two different filters differs at the pattern's sharp edges.
      EXPECT_LT(MeanAbsDiff(f->bgr, expected), full_size ? 2.0 : 6.0) << "frame " << n;
      ++n;
    }
    EXPECT_EQ(n, clip.shown.size());
  }
}

// Phones and messaging apps store portrait frames, and sizes that are not a multiple of 8 or 16.
TEST(Video, EveryFrameSizeDecodesAsFfmpegShowsIt) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const std::vector<cv::Size> sizes = {{540, 960}, {480, 854},  {854, 480},
                                       {900, 506}, {1000, 562}, {202, 114}};
  // 202x114 stays at its size: never scaled up.
  for (const cv::Size& s : sizes) {
    const PatternClip clip = MakePatternClip(fmt::format("size_{}x{}.mp4", s.width, s.height),
                                             s.width, s.height, 4, "-c:v libx264 -pix_fmt yuv420p");
    ExpectDecodedAsShown(clip, 300);
  }
  // 4K, as phones record it: only its first frame, scaled to the working size.
  ExpectDecodedAsShown(
      MakePatternClip("uhd.mp4", 3840, 2160, 1, "-c:v libx264 -preset ultrafast -pix_fmt yuv420p"),
      960);
  // 4:2:0 needs even sizes; 4:4:4 takes odd ones.
  ExpectDecodedAsShown(MakePatternClip("odd.mp4", 161, 91, 4, "-c:v libx264 -pix_fmt yuv444p"),
                       100);
}

TEST(Video, TenBitHevcDecodes) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const PatternClip clip = MakePatternClip(
      "hevc10.mov", 480, 270, 4, "-c:v libx265 -x265-params log-level=none -pix_fmt yuv420p10le");
  EXPECT_EQ(VideoReader(clip.path).info().codec, "hevc");
  ExpectDecodedAsShown(clip, 240);
}

// Phones vary the frame interval with the light; each frame keeps its own presentation time.
TEST(Video, VariableFrameTimesAreKept) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path clip = WriteClip(TestDir() / "cfr.mp4", 10);
  const fs::path vfr = TestDir() / "vfr.mp4";
  // Frame n at n/10 s for the first five, then 0.3 s apart.
  RunFfmpeg(clip,
            "-vf \"setpts='if(lt(N,5),N/10,0.4+(N-4)*0.3)/TB'\" -fps_mode passthrough "
            "-c:v libx264 -pix_fmt yuv420p",
            vfr);
  VideoReader reader(vfr);
  std::vector<double> t;
  while (auto f = reader.Next()) t.push_back(f->t_s);
  ASSERT_EQ(t.size(), 10u);
  for (int n = 0; n < 10; ++n) {
    EXPECT_NEAR(t[n], n < 5 ? n / 10.0 : 0.4 + (n - 4) * 0.3, 1e-3) << "frame " << n;
  }
}

TEST(Video, AudioTracksAreIgnored) {
  if (!HaveFfmpegTool()) GTEST_SKIP() << "the ffmpeg tool is not installed";
  const fs::path clip = WriteClip(TestDir() / "silent.mp4", 12);
  const fs::path with_audio = TestDir() / "with_audio.mov";
  const std::string cmd = fmt::format(
      "ffmpeg -hide_banner -loglevel error -y -f lavfi -i sine=frequency=440:duration=2 -i '{}' "
      "-map 0:a -map 1:v -c:v copy -c:a aac -shortest '{}'",
      clip.string(), with_audio.string());
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  VideoReader reader(with_audio);
  int n = 0;
  while (auto f = reader.Next()) {
    EXPECT_LT(MeanAbsDiff(f->bgr, TestFrame(160, 96, n)), 6.0) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, 12);
}

TEST(Video, WriterRejectsOddSize) {
  VideoWriterOptions wo;
  wo.width = 161;
  EXPECT_THROW(wo.Check(), InputError);
}

}  // namespace
}  // namespace stemmap
