#include "stemmap/video/ffmpeg_log.h"

extern "C" {
#include <libavutil/log.h>
}

#include <spdlog/spdlog.h>

#include <cstdarg>
#include <mutex>
#include <string_view>

namespace stemmap {

namespace {

// FFmpeg's messages go to our log at debug level: stderr carries stemmap's own lines only.
void LogFfmpegMessage(void* context, int level, const char* format, va_list args) {
  if (level > av_log_get_level() || !spdlog::should_log(spdlog::level::debug)) return;
  char line[1024];
  int print_prefix = 1;
  av_log_format_line2(context, level, format, args, line, sizeof(line), &print_prefix);
  std::string_view text(line);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  if (!text.empty()) spdlog::debug("ffmpeg: {}", text);
}

}  // namespace

void RouteFfmpegLog() {
  static std::once_flag once;
  std::call_once(once, [] {
    av_log_set_level(AV_LOG_WARNING);
    av_log_set_callback(LogFfmpegMessage);
  });
}

}  // namespace stemmap
