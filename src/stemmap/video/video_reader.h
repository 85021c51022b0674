#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

namespace stemmap {

// What the container says about a video, before any frame is decoded.
struct VideoInfo {
  int width = 0;  // of the frames returned: scaled, after the display rotation is applied
  int height = 0;
  int full_width = 0;  // as stored, after the display rotation is applied
  int full_height = 0;
  double fps = 0.0;  // average frame rate
  double duration_s = 0.0;
  int64_t frame_count = 0;  // container's estimate; may be 0 when unknown
  int rotation_deg = 0;     // clockwise rotation applied to decoded frames (0, 90, 180, 270)
  std::string codec;
  // When the recording was made, as the file says (its `creation_time` tag, ISO 8601 UTC, as
  // phones write it); empty when the file does not say.
  std::string creation_time;
};

struct DecodedFrame {
  int64_t index = 0;      // 0-based order of decoding
  double t_s = 0.0;       // presentation time from the stream, relative to the first frame
  cv::Mat bgr;            // CV_8UC3, rotated upright, scaled to the requested size
  cv::Mat gray_full;      // CV_8U, rotated upright, full resolution (VideoReaderOptions::full_gray)
  bool converted = true;  // false: VideoReaderOptions::wanted skipped it (no images)
  // The decoder met damaged data in it and filled the gap by guessing (error concealment): its
  // picture is partly made up.
  bool damaged = false;
};

struct VideoReaderOptions {
  // Resize so the longer side is at most this many pixels (0 = keep the full resolution).
  int max_long_side_px = 0;
  // Also return each frame's luma at full resolution, for measurements finer than tracking.
  bool full_gray = false;
  int threads = 2;
  // Frames decoded ahead on a background thread while the caller works on earlier ones
  // (0 = decode on the caller's thread). Frames arrive in the same order either way.
  int prefetch_frames = 0;
  // Which frames need images: the others are still decoded (the codec needs them) and returned
  // with their index and time, but not converted, which costs as much as decoding at 1080p.
  // Called on the decoding thread, so it must not touch state the caller changes. Empty: all.
  std::function<bool(const VideoInfo& info, int64_t index, double t_s)> wanted;
};

// Every how many frames a video of `fps` is sampled to work at about `wanted_fps` (>= 1).
int FrameStride(double fps, double wanted_fps);

// Decodes a video file (any codec and container FFmpeg reads: H.264/HEVC in mp4/mov, ...) to BGR
// frames in display orientation. Throws InputError when the file cannot be opened or holds no
// video stream. Corrupt packets are skipped and counted. With prefetching, an error on the
// background thread surfaces from the Next() call that would have met it.
class VideoReader {
 public:
  VideoReader(const std::filesystem::path& path, const VideoReaderOptions& options = {});
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  const VideoInfo& info() const;
  // The next frame, or nullopt at the end of the stream.
  std::optional<DecodedFrame> Next();
  // Packets the decoder rejected so far (all of them once Next() has returned nullopt).
  int corrupt_packets() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stemmap
