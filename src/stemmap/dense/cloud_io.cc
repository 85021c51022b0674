#include "stemmap/dense/cloud_io.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::dense {

namespace {

// The header after the vertex count, as written; a reader of any PLY skips what it does not use.
constexpr std::string_view kProperties =
    "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
    "property uchar green\nproperty uchar blue\nproperty float ox\nproperty float oy\n"
    "property float oz\nproperty int keyframe\nproperty char trunk\nproperty uchar "
    "view_bottom\nend_header\n";
constexpr std::string_view kStart = "ply\nformat binary_little_endian 1.0\nelement vertex ";
constexpr size_t kRecordBytes = 3 * 4 + 3 + 3 * 4 + 4 + 1 + 1;
// Clouds written before the view's bottom edge was kept: the same points without it.
constexpr std::string_view kPropertiesWithoutViewBottom =
    "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
    "property uchar green\nproperty uchar blue\nproperty float ox\nproperty float oy\n"
    "property float oz\nproperty int keyframe\nproperty char trunk\nend_header\n";

}  // namespace

void WriteCloudPly(const std::filesystem::path& path, const std::vector<CloudPoint>& pts) {
  std::string s = fmt::format("{}{}\n{}", kStart, pts.size(), kProperties);
  const size_t header = s.size();
  s.resize(header + kRecordBytes * pts.size());
  char* p = s.data() + header;
  for (const CloudPoint& c : pts) {
    std::memcpy(p, c.world.data(), 12);
    p[12] = static_cast<char>(c.bgr[2]);
    p[13] = static_cast<char>(c.bgr[1]);
    p[14] = static_cast<char>(c.bgr[0]);
    std::memcpy(p + 15, c.origin.data(), 12);
    const int32_t keyframe = c.keyframe;
    std::memcpy(p + 27, &keyframe, 4);
    p[31] = static_cast<char>(c.trunk);
    p[32] = static_cast<char>(c.at_view_bottom ? 1 : 0);
    p += kRecordBytes;
  }
  WriteFileAtomic(path, s);
}

std::vector<CloudPoint> ReadCloudPly(const std::filesystem::path& path) {
  const std::string s = ReadFileToString(path);
  const auto refuse = [&](const std::string& why) {
    return InputError(fmt::format("{}: {} (not a cloud stemmap wrote)", path.string(), why));
  };
  if (s.compare(0, kStart.size(), kStart) != 0) throw refuse("no binary PLY header");
  const size_t count_end = s.find('\n', kStart.size());
  if (count_end == std::string::npos || count_end == kStart.size() ||
      count_end - kStart.size() > 12) {
    throw refuse("no vertex count");
  }
  uint64_t n = 0;
  for (size_t i = kStart.size(); i < count_end; ++i) {
    if (s[i] < '0' || s[i] > '9') throw refuse("no vertex count");
    n = 10 * n + static_cast<uint64_t>(s[i] - '0');
  }
  const bool with_view_bottom = s.compare(count_end + 1, kProperties.size(), kProperties) == 0;
  if (!with_view_bottom && s.compare(count_end + 1, kPropertiesWithoutViewBottom.size(),
                                     kPropertiesWithoutViewBottom) != 0) {
    throw refuse("other point properties");
  }
  const size_t header =
      count_end + 1 + (with_view_bottom ? kProperties.size() : kPropertiesWithoutViewBottom.size());
  const size_t record_bytes = with_view_bottom ? kRecordBytes : kRecordBytes - 1;
  if ((s.size() - header) != n * record_bytes) {
    throw refuse(fmt::format("{} bytes of points where {} points need {}", s.size() - header, n,
                             n * record_bytes));
  }
  std::vector<CloudPoint> pts(n);
  const char* p = s.data() + header;
  for (CloudPoint& c : pts) {
    std::memcpy(c.world.data(), p, 12);
    c.bgr = cv::Vec3b(static_cast<uint8_t>(p[14]), static_cast<uint8_t>(p[13]),
                      static_cast<uint8_t>(p[12]));
    std::memcpy(c.origin.data(), p + 15, 12);
    int32_t keyframe = 0;
    std::memcpy(&keyframe, p + 27, 4);
    c.keyframe = keyframe;
    c.trunk = static_cast<int8_t>(p[31]);
    if (!c.world.allFinite() || !c.origin.allFinite()) throw refuse("a point that is not finite");
    if (keyframe < 0 || c.trunk < -1 || c.trunk > 1) throw refuse("a point's keyframe or label");
    if (with_view_bottom) {
      if (p[32] != 0 && p[32] != 1) throw refuse("a point's view-bottom mark");
      c.at_view_bottom = p[32] == 1;
    }
    p += record_bytes;
  }
  return pts;
}

}  // namespace stemmap::dense
