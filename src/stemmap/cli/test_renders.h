// Simulated captures that end-to-end tests share. Rendering is the slow part of those tests under
// the sanitizers, and each test runs in a process of its own, so a capture is rendered once into
// a folder of its name and reused. The folder is STEMMAP_TEST_RENDERS when set (CI points its
// sanitizer build at the plain build's renders: the renderer's own tests still run under the
// sanitizers), else `fallback`. A test that is given no such folder renders its own capture.
#ifndef STEMMAP_CLI_TEST_RENDERS_H_
#define STEMMAP_CLI_TEST_RENDERS_H_

#include <cstdlib>
#include <filesystem>
#include <string>

namespace stemmap {

// Where the shared captures are kept: STEMMAP_TEST_RENDERS, else `fallback` (empty: none).
inline std::filesystem::path SharedRenders(const std::filesystem::path& fallback = {}) {
  const char* dir = std::getenv("STEMMAP_TEST_RENDERS");
  return dir != nullptr && *dir != '\0' ? std::filesystem::path(dir) : fallback;
}

// The capture `name` in `renders`, made by `render(folder)` when it is not there yet. Rendered
// into a folder of this process's and then renamed, so a capture another process is still
// rendering is never read half-made; the first to finish wins.
template <typename Render>
std::filesystem::path RenderedOnce(const std::filesystem::path& renders, const std::string& name,
                                   const std::string& process_tag, Render&& render) {
  namespace fs = std::filesystem;
  const fs::path done = renders / name;
  if (fs::exists(done / "video.mp4")) return done;
  const fs::path mine = renders / (name + ".rendering_" + process_tag);
  fs::remove_all(mine);
  fs::create_directories(renders);
  render(mine);
  std::error_code ec;
  fs::rename(mine, done, ec);  // another process may have finished it first
  if (ec) fs::remove_all(mine, ec);
  return done;
}

}  // namespace stemmap

#endif  // STEMMAP_CLI_TEST_RENDERS_H_
