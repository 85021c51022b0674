// LAS 1.4 R15 (ASPRS): a 375-byte public header, one variable-length record with the CRS as OGC
// WKT (user "LASF_Projection", record 2112; global encoding bit 4 says so), then 36-byte points
// of format 7. All numbers little-endian.
#include "stemmap/gis/las.h"

#include <fmt/format.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::gis {

namespace {

static_assert(std::endian::native == std::endian::little, "LAS is little-endian");

constexpr uint16_t kHeaderSize = 375;
constexpr uint16_t kVlrHeaderSize = 54;
constexpr uint8_t kPointFormat = 7;
constexpr uint16_t kPointSize = 36;
constexpr uint16_t kGlobalEncodingWkt = 1 << 4;
constexpr uint16_t kWktRecordId = 2112;
constexpr double kScale = 0.001;  // metres a coordinate step

class Writer {
 public:
  template <typename T>
  void Put(T v) {
    const size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &v, sizeof(T));
  }
  void PutText(const std::string& s, size_t width) {  // NUL-padded, cut to width
    for (size_t i = 0; i < width; ++i) Put<char>(i < s.size() ? s[i] : '\0');
  }
  void PutZeros(size_t n) { bytes_.resize(bytes_.size() + n, '\0'); }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

class Reader {
 public:
  Reader(const std::string& bytes, const std::filesystem::path& path)
      : bytes_(bytes), path_(path) {}
  template <typename T>
  T Get() {
    Need(sizeof(T));
    T v;
    std::memcpy(&v, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  std::string GetText(size_t width) {
    Need(width);
    std::string s(bytes_.data() + at_, width);
    at_ += width;
    return s.substr(0, s.find('\0'));
  }
  void Seek(size_t at) {
    if (at > bytes_.size()) Fail("an offset past its end");
    at_ = at;
  }
  size_t at() const { return at_; }
  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(fmt::format("{}: not a LAS 1.4 file stemmap reads: {}", path_.string(), what));
  }

 private:
  void Need(size_t n) const {
    if (at_ + n > bytes_.size()) Fail("it ends early");
  }
  const std::string& bytes_;
  const std::filesystem::path& path_;
  size_t at_ = 0;
};

std::string CrsWkt(const Georeference& georef) {
  const OGRSpatialReference& srs = georef.ProjectedCrs() ? *georef.ProjectedCrs() : georef.GisCrs();
  char* wkt = nullptr;
  // WKT1 is what every LAS reader in use parses.
  const char* const options[] = {"FORMAT=WKT1", nullptr};
  srs.exportToWkt(&wkt, options);
  std::string s = wkt ? wkt : "";
  CPLFree(wkt);
  return s;
}

int32_t Scaled(double v, double offset) {
  const double steps = std::round((v - offset) / kScale);
  if (!(std::abs(steps) < std::numeric_limits<int32_t>::max())) {
    throw ProcessingError("a cloud point lies too far from the plot for LAS coordinates");
  }
  return static_cast<int32_t>(steps);
}

void PutHeader(Writer* w, uint32_t point_data_offset, uint64_t n_points,
               const Eigen::Vector3d& offset, const Eigen::Vector3d& min,
               const Eigen::Vector3d& max) {
  w->PutText("LASF", 4);
  w->Put<uint16_t>(0);  // file source ID
  w->Put<uint16_t>(kGlobalEncodingWkt);
  w->PutZeros(16);  // project GUID
  w->Put<uint8_t>(1);
  w->Put<uint8_t>(4);
  w->PutText("stemmap fused cloud", 32);
  w->PutText(fmt::format("stemmap {}", STEMMAP_VERSION), 32);
  // Creation day and year stay 0 (unknown, as the format allows): the same input gives the same
  // file.
  w->Put<uint16_t>(0);
  w->Put<uint16_t>(0);
  w->Put<uint16_t>(kHeaderSize);
  w->Put<uint32_t>(point_data_offset);
  w->Put<uint32_t>(1);  // VLRs
  w->Put<uint8_t>(kPointFormat);
  w->Put<uint16_t>(kPointSize);
  w->Put<uint32_t>(0);  // legacy point count: 0 for formats 6-10
  w->PutZeros(5 * 4);   // legacy points by return
  for (int i = 0; i < 3; ++i) w->Put<double>(kScale);
  for (int i = 0; i < 3; ++i) w->Put<double>(offset[i]);
  for (int i = 0; i < 3; ++i) {
    w->Put<double>(max[i]);
    w->Put<double>(min[i]);
  }
  w->Put<uint64_t>(0);  // waveform data
  w->Put<uint64_t>(0);  // first EVLR
  w->Put<uint32_t>(0);  // EVLRs
  w->Put<uint64_t>(n_points);
  w->Put<uint64_t>(n_points);  // every point is a first (and only) return
  w->PutZeros(14 * 8);
}

}  // namespace

void WriteLas(const std::filesystem::path& path, const std::vector<dense::CloudPoint>& points,
              const std::vector<double>& keyframe_t_s, const Georeference& georef) {
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(points.size());
  for (const dense::CloudPoint& p : points) xy.emplace_back(p.world.x(), p.world.y());
  const std::vector<Eigen::Vector2d> map_xy =
      georef.HasCentre() ? georef.ProjectedXy(xy) : georef.GisXy(xy);
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d q(map_xy[i].x(), map_xy[i].y(), points[i].world.z());
    min = i == 0 ? q : Eigen::Vector3d(min.cwiseMin(q));
    max = i == 0 ? q : Eigen::Vector3d(max.cwiseMax(q));
  }
  // Whole metres near the cloud's middle keep every coordinate well inside 32 bits.
  const Eigen::Vector3d offset = (0.5 * (min + max)).array().round();
  const std::string wkt = CrsWkt(georef) + '\0';
  const uint32_t point_data_offset = kHeaderSize + kVlrHeaderSize + wkt.size();
  Writer w;
  w.bytes().reserve(point_data_offset + points.size() * kPointSize);
  PutHeader(&w, point_data_offset, points.size(), offset, min, max);
  w.Put<uint16_t>(0);  // reserved
  w.PutText("LASF_Projection", 16);
  w.Put<uint16_t>(kWktRecordId);
  w.Put<uint16_t>(static_cast<uint16_t>(wkt.size()));
  w.PutText("OGC coordinate system WKT", 32);
  w.PutText(wkt, wkt.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const dense::CloudPoint& p = points[i];
    w.Put<int32_t>(Scaled(map_xy[i].x(), offset.x()));
    w.Put<int32_t>(Scaled(map_xy[i].y(), offset.y()));
    w.Put<int32_t>(Scaled(p.world.z(), offset.z()));
    w.Put<uint16_t>(0);    // intensity
    w.Put<uint8_t>(0x11);  // return 1 of 1
    w.Put<uint8_t>(0);     // classification flags, channel, scan direction, edge
    w.Put<uint8_t>(1);     // class 1: unclassified
    w.Put<uint8_t>(0);     // user data
    w.Put<int16_t>(0);     // scan angle
    w.Put<uint16_t>(static_cast<uint16_t>(std::clamp(p.keyframe, 0, 65535)));
    const bool timed = p.keyframe >= 0 && p.keyframe < static_cast<int>(keyframe_t_s.size());
    w.Put<double>(timed ? keyframe_t_s[p.keyframe] : 0.0);
    w.Put<uint16_t>(static_cast<uint16_t>(p.bgr[2] * 257));
    w.Put<uint16_t>(static_cast<uint16_t>(p.bgr[1] * 257));
    w.Put<uint16_t>(static_cast<uint16_t>(p.bgr[0] * 257));
  }
  WriteFileAtomic(path, w.bytes());
}

LasFile ReadLas(const std::filesystem::path& path) {
  const std::string bytes = ReadFileToString(path);
  Reader r(bytes, path);
  LasFile f;
  if (r.GetText(4) != "LASF") r.Fail("no LASF signature");
  r.Get<uint16_t>();
  const uint16_t encoding = r.Get<uint16_t>();
  r.Seek(24);
  const int major = r.Get<uint8_t>(), minor = r.Get<uint8_t>();
  if (major != 1 || minor != 4) r.Fail(fmt::format("version {}.{}", major, minor));
  f.system_identifier = r.GetText(32);
  f.generating_software = r.GetText(32);
  r.Get<uint16_t>();
  r.Get<uint16_t>();
  if (r.Get<uint16_t>() != kHeaderSize) r.Fail("a header size other than 375");
  const uint32_t point_data_offset = r.Get<uint32_t>();
  const uint32_t n_vlrs = r.Get<uint32_t>();
  f.point_format = r.Get<uint8_t>();
  const uint16_t point_size = r.Get<uint16_t>();
  if (f.point_format != kPointFormat || point_size < kPointSize) {
    r.Fail(fmt::format("point format {} of {} bytes", f.point_format, point_size));
  }
  r.Seek(131);
  for (int i = 0; i < 3; ++i) f.scale[i] = r.Get<double>();
  for (int i = 0; i < 3; ++i) f.offset[i] = r.Get<double>();
  for (int i = 0; i < 3; ++i) {
    f.max[i] = r.Get<double>();
    f.min[i] = r.Get<double>();
  }
  if (!f.scale.allFinite() || !(f.scale.minCoeff() > 0) || !f.offset.allFinite()) {
    r.Fail("a scale or offset that is not a positive finite number");
  }
  r.Seek(247);
  const uint64_t n_points = r.Get<uint64_t>();
  for (uint32_t v = 0, at = kHeaderSize; v < n_vlrs; ++v) {
    r.Seek(at);
    r.Get<uint16_t>();
    const std::string user = r.GetText(16);
    const uint16_t record = r.Get<uint16_t>();
    const uint16_t length = r.Get<uint16_t>();
    r.GetText(32);
    if (user == "LASF_Projection" && record == kWktRecordId) f.wkt = r.GetText(length);
    at += kVlrHeaderSize + length;
  }
  if ((encoding & kGlobalEncodingWkt) == 0 && !f.wkt.empty()) r.Fail("a WKT CRS not flagged");
  if (n_points > (bytes.size() - std::min<size_t>(bytes.size(), point_data_offset)) / point_size) {
    r.Fail(fmt::format("{} points announced, fewer there", n_points));
  }
  f.points.resize(n_points);
  for (uint64_t i = 0; i < n_points; ++i) {
    r.Seek(point_data_offset + i * point_size);
    LasPoint& p = f.points[i];
    for (int k = 0; k < 3; ++k) p.xyz[k] = r.Get<int32_t>() * f.scale[k] + f.offset[k];
    r.Seek(r.at() + 8);
    p.point_source_id = r.Get<uint16_t>();
    p.gps_time = r.Get<double>();
    p.red = r.Get<uint16_t>();
    p.green = r.Get<uint16_t>();
    p.blue = r.Get<uint16_t>();
  }
  return f;
}

}  // namespace stemmap::gis
