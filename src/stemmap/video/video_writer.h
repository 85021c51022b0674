#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>

namespace stemmap {

struct VideoWriterOptions {
  int width = 1920;
  int height = 1080;
  double fps = 30.0;
  double bitrate_mbps = 17.0;  // typical of a phone's 1080p30 H.264 recording
  int gop_frames = 30;         // phones place a key frame about every second
  int threads = 2;
  void Check() const;
};

// Encodes BGR frames to H.264 in an MP4 file with libavcodec/libavformat. The file appears at
// `path` only after Close() succeeds (written to a temporary name and renamed).
class VideoWriter {
 public:
  VideoWriter(const std::filesystem::path& path, const VideoWriterOptions& options);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // `bgr` must be CV_8UC3 of the configured size.
  void Write(const cv::Mat& bgr);
  // Flushes the encoder, finishes the container and moves the file into place.
  void Close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stemmap
