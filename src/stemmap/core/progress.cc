#include "stemmap/core/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace stemmap {

Progress::Progress(std::string label, int64_t total)
    : label_(std::move(label)),
      total_(std::max<int64_t>(total, 1)),
      tty_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() { Finish(); }

void Progress::Update(int64_t done) {
  const auto now = std::chrono::steady_clock::now();
  const int percent = static_cast<int>(100 * std::clamp<int64_t>(done, 0, total_) / total_);
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(200) && done < total_) return;
    last_draw_ = now;
    const int width = 30;
    const int filled = width * percent / 100;
    fmt::print(stderr, "\r{:<12} [{}{}] {:3d}% {:6.1f}s", label_, std::string(filled, '#'),
               std::string(width - filled, '.'), percent, elapsed_s);
    std::fflush(stderr);
  } else if (percent / 10 != last_percent_ / 10) {
    fmt::print(stderr, "{}: {}% ({:.1f}s)\n", label_, percent, elapsed_s);
  }
  last_percent_ = percent;
}

void Progress::Finish() {
  if (finished_) return;
  finished_ = true;
  if (tty_ && last_percent_ >= 0) fmt::print(stderr, "\n");
}

}  // namespace stemmap
