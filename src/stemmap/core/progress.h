#pragma once

#include <chrono>
#include <string>

namespace stemmap {

// A one-line progress bar on stderr for long stages. Redraws at most a few times per second and
// prints plain lines instead when stderr is not a terminal (logs, CI).
class Progress {
 public:
  Progress(std::string label, int64_t total);
  ~Progress();
  void Update(int64_t done);
  void Finish();

 private:
  std::string label_;
  int64_t total_;
  bool tty_;
  bool finished_ = false;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace stemmap
