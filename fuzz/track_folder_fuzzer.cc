// What `process --from-track DIR` reads: summary.json, then keyframes.tum, then trajectory.tum,
// the input's parts split at lines of "---".
#include <string>

#include "fuzz_file.h"
#include "stemmap/track/track.h"
#include "stemmap/track/track_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace fs = std::filesystem;
  const std::string text(stemmap::fuzz::AsText(data, size));
  std::string parts[3];
  size_t at = 0;
  for (int i = 0; i < 3; ++i) {
    const size_t end = i < 2 ? text.find("\n---\n", at) : std::string::npos;
    parts[i] = text.substr(std::min(at, text.size()), end == std::string::npos ? end : end - at);
    at = end == std::string::npos ? text.size() : end + 5;
  }
  const fs::path dir = stemmap::fuzz::WriteInput("summary.json", parts[0]).parent_path();
  stemmap::fuzz::WriteInput("keyframes.tum", parts[1]);
  stemmap::fuzz::WriteInput("trajectory.tum", parts[2]);
  return stemmap::fuzz::Parse([&] { stemmap::track::ReadTrackFolder(dir); });
}
