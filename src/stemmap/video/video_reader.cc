#include "stemmap/video/video_reader.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/display.h>
#include <libavutil/imgutils.h>
#include <libavutil/log.h>
#include <libswscale/swscale.h>
}

#include <fmt/format.h>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <opencv2/core.hpp>
#include <thread>

#include "stemmap/core/error.h"
#include "stemmap/video/ffmpeg_log.h"

namespace stemmap {

namespace fs = std::filesystem;

namespace {

std::string AvError(int ret) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
  av_strerror(ret, buf, sizeof(buf));
  return buf;
}

// Clockwise rotation in degrees that makes decoded frames upright.
int DisplayRotationDeg(const AVStream* stream) {
  const uint8_t* matrix = av_stream_get_side_data(stream, AV_PKT_DATA_DISPLAYMATRIX, nullptr);
  if (!matrix) return 0;
  // av_display_rotation_get gives the counter-clockwise angle the frame must be rotated by.
  const double ccw = av_display_rotation_get(reinterpret_cast<const int32_t*>(matrix));
  if (std::isnan(ccw)) return 0;
  int cw = static_cast<int>(std::lround(-ccw)) % 360;
  if (cw < 0) cw += 360;
  return (cw + 45) / 90 * 90 % 360;
}

// The decoded frame converted and scaled to w x h in `format` (an OpenCV image of `cv_type`),
// through a conversion context cached in *ctx.
//
// Two faults of swscale (FFmpeg 5.1) are kept away here. Its unscaled YUV-to-RGB converter works
// in blocks of 16 pixels: for other widths it leaves a row's last pixels unwritten (854 px: 6 of
// them) or writes past the row's end (540 px: 12 bytes), so that case takes the exact path
// (SWS_ACCURATE_RND), which the benchmark's sizes (multiples of 16) never need. And its vector
// stores may reach a few bytes past a row: into the next row, written afterwards, or, after the
// last row, past the image; so it writes into a buffer with spare rows below the image, which is
// then copied out. (The image must not stay a view of that buffer: OpenCV's filters read past a
// view's edges into its parent, here the unwritten spare rows, instead of making a border.)
cv::Mat Convert(SwsContext** ctx, const AVFrame* frame, int w, int h, AVPixelFormat format,
                int cv_type) {
  const bool unscaled_rgb = w == frame->width && h == frame->height && format != AV_PIX_FMT_GRAY8;
  const int flags = SWS_AREA | (unscaled_rgb && w % 16 != 0 ? SWS_ACCURATE_RND : 0);
  *ctx = sws_getCachedContext(*ctx, frame->width, frame->height,
                              static_cast<AVPixelFormat>(frame->format), w, h, format, flags,
                              nullptr, nullptr, nullptr);
  if (!*ctx) {
    throw ProcessingError(fmt::format("cannot convert decoded {}x{} frames of pixel format {}",
                                      frame->width, frame->height, frame->format));
  }
  constexpr int kSpareBytes = 256;  // more than any store of swscale's reaches past a row
  const int row_bytes = w * CV_ELEM_SIZE(cv_type);
  const int spare_rows = (kSpareBytes + row_bytes - 1) / row_bytes;
  cv::Mat buffer(h + spare_rows, w, cv_type);
  uint8_t* dst[4] = {buffer.data, nullptr, nullptr, nullptr};
  const int dst_stride[4] = {static_cast<int>(buffer.step[0]), 0, 0, 0};
  const int rows = sws_scale(*ctx, frame->data, frame->linesize, 0, frame->height, dst, dst_stride);
  if (rows != h) {
    throw ProcessingError(fmt::format("converting a {}x{} frame gave {} of {} rows", frame->width,
                                      frame->height, rows, h));
  }
  return buffer.rowRange(0, h).clone();
}

// The image turned clockwise by `rotation_deg` (0, 90, 180 or 270).
cv::Mat Upright(const cv::Mat& img, int rotation_deg) {
  cv::Mat out;
  switch (rotation_deg) {
    case 90:
      cv::rotate(img, out, cv::ROTATE_90_CLOCKWISE);
      return out;
    case 180:
      cv::rotate(img, out, cv::ROTATE_180);
      return out;
    case 270:
      cv::rotate(img, out, cv::ROTATE_90_COUNTERCLOCKWISE);
      return out;
    default:
      return img;
  }
}

}  // namespace

struct VideoReader::Impl {
  fs::path path;
  VideoReaderOptions options;
  VideoInfo info;
  AVFormatContext* fmt = nullptr;
  AVCodecContext* dec = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  SwsContext* sws_gray = nullptr;
  int stream_index = -1;
  int64_t decoded = 0;
  std::atomic<int> corrupt = 0;
  bool flushing = false;
  bool done = false;
  double first_t_s = NAN;
  int out_w = 0, out_h = 0;    // decoded-orientation output size before rotation
  int full_w = 0, full_h = 0;  // decoded-orientation stored size before rotation

  // Prefetching: the background thread fills `queue` up to options.prefetch_frames.
  std::thread worker;
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<DecodedFrame> queue;
  bool worker_done = false, stop = false;
  std::exception_ptr worker_error;

  std::optional<DecodedFrame> Decode();
  void Prefetch();

  ~Impl() {
    if (worker.joinable()) {
      {
        const std::lock_guard lock(mutex);
        stop = true;
      }
      changed.notify_all();
      worker.join();
    }
    sws_freeContext(sws);
    sws_freeContext(sws_gray);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&dec);
    avformat_close_input(&fmt);
  }
};

VideoReader::VideoReader(const fs::path& path, const VideoReaderOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  // Problems surface as exceptions; FFmpeg's own chatter would bury the progress bar.
  RouteFfmpegLog();
  m.path = path;
  m.options = options;
  if (!fs::exists(path)) throw InputError(fmt::format("video {} does not exist", path.string()));
  if (fs::is_directory(path)) {
    throw InputError(fmt::format("{} is a folder, not a video", path.string()));
  }
  int ret = avformat_open_input(&m.fmt, path.c_str(), nullptr, nullptr);
  if (ret < 0) {
    throw InputError(fmt::format(
        "cannot open video {}: {} (not a video, or damaged or incomplete: a copy cut short loses "
        "the index that most phones write at the end)",
        path.string(), AvError(ret)));
  }
  ret = avformat_find_stream_info(m.fmt, nullptr);
  if (ret < 0) {
    throw InputError(fmt::format("cannot read video {}: {} (damaged or incomplete)", path.string(),
                                 AvError(ret)));
  }
  const AVCodec* codec = nullptr;
  m.stream_index = av_find_best_stream(m.fmt, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (m.stream_index < 0 || !codec) {
    throw InputError(fmt::format("{} holds no decodable video stream", path.string()));
  }
  AVStream* stream = m.fmt->streams[m.stream_index];
  m.dec = avcodec_alloc_context3(codec);
  if (!m.dec) throw ProcessingError("out of memory opening a video decoder");
  ret = avcodec_parameters_to_context(m.dec, stream->codecpar);
  if (ret < 0) {
    throw InputError(fmt::format("cannot decode {}: {}", path.string(), AvError(ret)));
  }
  m.dec->thread_count = options.threads;
  ret = avcodec_open2(m.dec, codec, nullptr);
  if (ret < 0) {
    throw InputError(fmt::format("cannot decode {}: {}", path.string(), AvError(ret)));
  }
  if (m.dec->width <= 0 || m.dec->height <= 0) {
    throw InputError(fmt::format("{} has no frame size", path.string()));
  }

  m.info.codec = codec->name;
  m.info.rotation_deg = DisplayRotationDeg(stream);
  for (const AVDictionary* tags : {static_cast<const AVDictionary*>(m.fmt->metadata),
                                   static_cast<const AVDictionary*>(stream->metadata)}) {
    const AVDictionaryEntry* e = av_dict_get(tags, "creation_time", nullptr, 0);
    if (e && e->value && m.info.creation_time.empty()) m.info.creation_time = e->value;
  }
  const AVRational rate =
      stream->avg_frame_rate.num > 0 ? stream->avg_frame_rate : stream->r_frame_rate;
  m.info.fps = rate.num > 0 && rate.den > 0 ? av_q2d(rate) : 0.0;
  if (stream->duration > 0) {
    m.info.duration_s = stream->duration * av_q2d(stream->time_base);
  } else if (m.fmt->duration > 0) {
    m.info.duration_s = m.fmt->duration / static_cast<double>(AV_TIME_BASE);
  }
  m.info.frame_count = stream->nb_frames;
  double scale = 1.0;
  const int long_side = std::max(m.dec->width, m.dec->height);
  if (options.max_long_side_px > 0 && long_side > options.max_long_side_px) {
    scale = static_cast<double>(options.max_long_side_px) / long_side;
  }
  m.out_w = std::max(2, static_cast<int>(std::lround(m.dec->width * scale)));
  m.out_h = std::max(2, static_cast<int>(std::lround(m.dec->height * scale)));
  m.full_w = m.dec->width;
  m.full_h = m.dec->height;
  const bool swap = m.info.rotation_deg == 90 || m.info.rotation_deg == 270;
  m.info.width = swap ? m.out_h : m.out_w;
  m.info.height = swap ? m.out_w : m.out_h;
  m.info.full_width = swap ? m.full_h : m.full_w;
  m.info.full_height = swap ? m.full_w : m.full_h;
  m.frame = av_frame_alloc();
  m.packet = av_packet_alloc();
  if (!m.frame || !m.packet) throw ProcessingError("out of memory opening a video");
  if (options.prefetch_frames > 0) m.worker = std::thread([&m] { m.Prefetch(); });
}

VideoReader::~VideoReader() = default;

int FrameStride(double fps, double wanted_fps) {
  if (!(fps > 0)) fps = 30.0;
  return std::max(1, static_cast<int>(std::lround(fps / wanted_fps)));
}

const VideoInfo& VideoReader::info() const { return impl_->info; }
int VideoReader::corrupt_packets() const { return impl_->corrupt; }

std::optional<DecodedFrame> VideoReader::Next() {
  Impl& m = *impl_;
  if (!m.worker.joinable()) return m.Decode();
  std::unique_lock lock(m.mutex);
  m.changed.wait(lock, [&m] { return !m.queue.empty() || m.worker_done; });
  if (m.queue.empty()) {
    if (m.worker_error) std::rethrow_exception(std::exchange(m.worker_error, nullptr));
    return std::nullopt;
  }
  DecodedFrame out = std::move(m.queue.front());
  m.queue.pop_front();
  lock.unlock();
  m.changed.notify_all();
  return out;
}

void VideoReader::Impl::Prefetch() {
  try {
    while (std::optional<DecodedFrame> f = Decode()) {
      std::unique_lock lock(mutex);
      changed.wait(lock, [this] {
        return stop || queue.size() < static_cast<size_t>(options.prefetch_frames);
      });
      if (stop) break;
      queue.push_back(std::move(*f));
      lock.unlock();
      changed.notify_all();
    }
  } catch (...) {
    const std::lock_guard lock(mutex);
    worker_error = std::current_exception();
  }
  {
    const std::lock_guard lock(mutex);
    worker_done = true;
  }
  changed.notify_all();
}

std::optional<DecodedFrame> VideoReader::Impl::Decode() {
  Impl& m = *this;
  while (!m.done) {
    int ret = avcodec_receive_frame(m.dec, m.frame);
    if (ret == 0) {
      const AVStream* stream = m.fmt->streams[m.stream_index];
      const int64_t pts = m.frame->best_effort_timestamp;
      double t_s = pts == AV_NOPTS_VALUE
                       ? (m.info.fps > 0 ? m.decoded / m.info.fps : static_cast<double>(m.decoded))
                       : pts * av_q2d(stream->time_base);
      if (std::isnan(m.first_t_s)) m.first_t_s = t_s;
      t_s -= m.first_t_s;
      DecodedFrame out;
      out.index = m.decoded++;
      out.t_s = t_s;
      out.damaged =
          m.frame->decode_error_flags != 0 || (m.frame->flags & AV_FRAME_FLAG_CORRUPT) != 0;
      out.converted = !m.options.wanted || m.options.wanted(m.info, out.index, t_s);
      if (out.converted) {
        // Frames whose size changes mid-stream are rescaled to the first size.
        out.bgr = Upright(Convert(&m.sws, m.frame, m.out_w, m.out_h, AV_PIX_FMT_BGR24, CV_8UC3),
                          m.info.rotation_deg);
        if (m.options.full_gray) {
          out.gray_full =
              Upright(Convert(&m.sws_gray, m.frame, m.full_w, m.full_h, AV_PIX_FMT_GRAY8, CV_8U),
                      m.info.rotation_deg);
        }
      }
      av_frame_unref(m.frame);
      return out;
    }
    if (ret == AVERROR_EOF) {
      m.done = true;
      break;
    }
    if (ret != AVERROR(EAGAIN)) {
      ++m.corrupt;  // a frame the decoder could not produce; go on with the next packet
    }
    if (m.flushing) {
      if (ret == AVERROR(EAGAIN)) m.done = true;
      continue;
    }
    ret = av_read_frame(m.fmt, m.packet);
    if (ret < 0) {
      m.flushing = true;
      avcodec_send_packet(m.dec, nullptr);
      continue;
    }
    if (m.packet->stream_index == m.stream_index) {
      if (avcodec_send_packet(m.dec, m.packet) < 0) ++m.corrupt;
    }
    av_packet_unref(m.packet);
  }
  return std::nullopt;
}

}  // namespace stemmap
