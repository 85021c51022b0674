#include "stemmap/video/video_writer.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include <fmt/format.h>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/video/ffmpeg_log.h"

namespace stemmap {

namespace fs = std::filesystem;

void VideoWriterOptions::Check() const {
  if (width < 16 || height < 16 || width % 2 || height % 2) {
    throw InputError(fmt::format("video size {}x{} must be even and at least 16", width, height));
  }
  if (!(fps >= 1.0 && fps <= 240.0)) throw InputError(fmt::format("fps {} out of [1, 240]", fps));
  if (!(bitrate_mbps > 0.05)) throw InputError("bitrate must exceed 0.05 Mbit/s");
}

struct VideoWriter::Impl {
  fs::path path, tmp_path;
  VideoWriterOptions options;
  AVFormatContext* fmt = nullptr;
  AVCodecContext* enc = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  int64_t next_pts = 0;
  bool open = false;

  ~Impl() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&enc);
    if (fmt) {
      if (fmt->pb) avio_closep(&fmt->pb);
      avformat_free_context(fmt);
    }
    if (open) {
      std::error_code ec;
      fs::remove(tmp_path, ec);
    }
  }

  void Check(int ret, const char* what) const {
    if (ret < 0) {
      char buf[AV_ERROR_MAX_STRING_SIZE] = {0};
      av_strerror(ret, buf, sizeof(buf));
      throw ProcessingError(
          fmt::format("video encoding ({}) failed for {}: {}", what, path.string(), buf));
    }
  }

  void Drain(bool flush) {
    Check(avcodec_send_frame(enc, flush ? nullptr : frame), "send frame");
    while (true) {
      const int ret = avcodec_receive_packet(enc, packet);
      if (ret == AVERROR(EAGAIN) || ret == AVERROR_EOF) break;
      Check(ret, "receive packet");
      av_packet_rescale_ts(packet, enc->time_base, stream->time_base);
      packet->stream_index = stream->index;
      Check(av_interleaved_write_frame(fmt, packet), "write packet");
    }
  }
};

VideoWriter::VideoWriter(const fs::path& path, const VideoWriterOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  Impl& m = *impl_;
  // Problems surface as exceptions; FFmpeg's own chatter would bury the progress bar.
  RouteFfmpegLog();
  m.path = path;
  m.options = options;
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  m.tmp_path = TempPathFor(path).replace_extension(".mp4");

  m.Check(avformat_alloc_output_context2(&m.fmt, nullptr, "mp4", m.tmp_path.c_str()), "container");
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (!codec) codec = avcodec_find_encoder(AV_CODEC_ID_H264);
  if (!codec) throw ProcessingError("no H.264 encoder in this FFmpeg build");
  m.stream = avformat_new_stream(m.fmt, nullptr);
  m.enc = avcodec_alloc_context3(codec);
  // Rational frame rate: 30 fps → 30/1, 29.97 → 30000/1001.
  const AVRational rate = av_d2q(options.fps, 100000);
  m.enc->width = options.width;
  m.enc->height = options.height;
  m.enc->time_base = av_inv_q(rate);
  m.enc->framerate = rate;
  m.enc->pix_fmt = AV_PIX_FMT_YUV420P;
  m.enc->gop_size = options.gop_frames;
  m.enc->max_b_frames = 0;  // phones rarely use B-frames in camera recordings
  m.enc->bit_rate = static_cast<int64_t>(options.bitrate_mbps * 1e6);
  m.enc->rc_max_rate = static_cast<int64_t>(options.bitrate_mbps * 1.5e6);
  m.enc->rc_buffer_size = static_cast<int>(options.bitrate_mbps * 2e6);
  m.enc->thread_count = options.threads;
  if (m.fmt->oformat->flags & AVFMT_GLOBALHEADER) m.enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  if (std::string(codec->name) == "libx264") {
    av_opt_set(m.enc->priv_data, "preset", "veryfast", 0);
    // Frame threads make x264's rate control depend on timing; slice threads keep the output
    // identical from run to run.
    av_opt_set(m.enc->priv_data, "x264-params", "sliced-threads=1", 0);
  }
  m.Check(avcodec_open2(m.enc, codec, nullptr), "open encoder");
  m.Check(avcodec_parameters_from_context(m.stream->codecpar, m.enc), "stream parameters");
  m.stream->time_base = m.enc->time_base;
  m.stream->avg_frame_rate = rate;
  m.Check(avio_open(&m.fmt->pb, m.tmp_path.c_str(), AVIO_FLAG_WRITE), "open file");
  m.open = true;
  m.Check(avformat_write_header(m.fmt, nullptr), "header");

  m.frame = av_frame_alloc();
  m.frame->format = m.enc->pix_fmt;
  m.frame->width = options.width;
  m.frame->height = options.height;
  m.Check(av_frame_get_buffer(m.frame, 0), "frame buffer");
  m.packet = av_packet_alloc();
  m.sws =
      sws_getContext(options.width, options.height, AV_PIX_FMT_BGR24, options.width, options.height,
                     AV_PIX_FMT_YUV420P, SWS_BICUBIC, nullptr, nullptr, nullptr);
  if (!m.sws) throw ProcessingError("cannot create colour converter for the video writer");
}

VideoWriter::~VideoWriter() = default;

void VideoWriter::Write(const cv::Mat& bgr) {
  Impl& m = *impl_;
  if (bgr.type() != CV_8UC3 || bgr.cols != m.options.width || bgr.rows != m.options.height) {
    throw ProcessingError(fmt::format("frame {}x{} does not match the video {}x{}", bgr.cols,
                                      bgr.rows, m.options.width, m.options.height));
  }
  m.Check(av_frame_make_writable(m.frame), "frame writable");
  const uint8_t* src[1] = {bgr.data};
  const int stride[1] = {static_cast<int>(bgr.step[0])};
  sws_scale(m.sws, src, stride, 0, bgr.rows, m.frame->data, m.frame->linesize);
  m.frame->pts = m.next_pts++;
  m.Drain(false);
}

void VideoWriter::Close() {
  Impl& m = *impl_;
  if (!m.open) return;
  m.Drain(true);
  m.Check(av_write_trailer(m.fmt), "trailer");
  avio_closep(&m.fmt->pb);
  m.open = false;
  CommitTempFile(m.tmp_path, m.path);
}

}  // namespace stemmap
