#include "stemmap/stems/stems.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>

#include "stemmap/core/error.h"

namespace stemmap::stems {

std::string_view FlagName(StemFlag flag) {
  switch (flag) {
    case StemFlag::kOccluded:
      return "occluded";
    case StemFlag::kOneSided:
      return "one_sided";
    case StemFlag::kFewViews:
      return "few_views";
    case StemFlag::kNoSilhouette:
      return "no_silhouette";
    case StemFlag::kDepthSmeared:
      return "depth_smeared";
    case StemFlag::kSilhouetteOnly:
      return "silhouette_only";
    case StemFlag::kWidthFromStand:
      return "width_from_stand";
  }
  return "unknown";
}

std::vector<std::string_view> StemFlags::Names() const {
  std::vector<std::string_view> names;
  for (int i = 0; i < kStemFlagCount; ++i) {
    if (Has(static_cast<StemFlag>(i))) names.push_back(FlagName(static_cast<StemFlag>(i)));
  }
  return names;
}

void StemOptions::Check() const {
  if (!(breast_height_m > 0.3 && breast_height_m < 3.0)) {
    throw InputError(fmt::format("breast height {} m is outside 0.3-3 m", breast_height_m));
  }
  if (!(search_radius_m > 1)) throw InputError("search radius must exceed 1 m");
  if (!(band_high_m > band_low_m)) throw InputError("detection band is empty");
  if (!(confirm_lean_deg > 0 && confirm_lean_deg <= max_lean_deg)) {
    throw InputError("the lean that needs confirming must lie in (0, max_lean_deg]");
  }
  if (!(lean_circle_max_off_share > 0)) {
    throw InputError(
        "the share of the radius within which a third's points lie on its circle must be positive");
  }
  if (!(lean_slice_min_points >= 2 && lean_slice_min_share >= 0 && lean_slice_min_share <= 1)) {
    throw InputError(
        "a third of the band holds a surface with at least 2 points (lean_slice_min_points) and "
        "a share in [0, 1] of the densest third's (lean_slice_min_share)");
  }
  if (!(mixed_part_lone_core_max_share >= 0 && mixed_part_lone_core_max_share <= 1)) {
    throw InputError("mixed_part_lone_core_max_share must be in [0, 1]");
  }
  if (!(weak_support_share >= 0 && weak_support_share <= 1)) {
    throw InputError("weak_support_share must be in [0, 1]");
  }
  if (!(free_space_veto > 0 && free_space_veto <= 1)) {
    throw InputError("free_space_veto must be in (0, 1]");
  }
}

nlohmann::json StemsResult::Summary() const {
  return {{"stems", stems.size()},
          {"components", components},
          {"rejected_size", rejected_size},
          {"rejected_vertical", rejected_vertical},
          {"vetoed_free_space", vetoed_free_space},
          {"larger_cloud_parts", larger_cloud_parts},
          {"larger_cloud_only", larger_cloud_only},
          {"silhouette_votes", silhouette_votes},
          {"mixed_part_cores", mixed_part_cores}};
}

int AttachLargerCloudParts(std::vector<Stem> more, double gap_m, std::vector<Stem>* found) {
  std::vector<double> attached_at(found->size(), std::numeric_limits<double>::infinity());
  for (Stem& m : more) {
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < found->size(); ++k) {
      const Stem& f = (*found)[k];
      const double d = (m.centre_xy - f.centre_xy).norm();
      if (d - 0.5 * (m.dbh_m + f.dbh_m) < gap_m && d < best_d)
        best = static_cast<int>(k), best_d = d;
    }
    if (best < 0 || best_d >= attached_at[best]) continue;
    Stem& f = (*found)[best];
    const bool differs = best_d > 0.05 || std::abs(m.dbh_m - f.dbh_m) > 0.2 * f.dbh_m;
    spdlog::debug(
        "stems: larger cloud's part at ({:.2f}, {:.2f}) dbh {:.3f} for ({:.2f}, {:.2f}) dbh "
        "{:.3f}: {}",
        m.centre_xy.x(), m.centre_xy.y(), m.dbh_m, f.centre_xy.x(), f.centre_xy.y(), f.dbh_m,
        differs ? "kept" : "the same");
    if (!differs) continue;
    m.alternatives.clear();
    f.larger_cloud_part = {std::move(m)};
    attached_at[best] = best_d;
  }
  return static_cast<int>(
      std::ranges::count_if(*found, [](const Stem& f) { return !f.larger_cloud_part.empty(); }));
}

std::vector<Stem> StemsAwayFrom(std::span<const Stem> more, double gap_m,
                                std::span<const Stem> found) {
  std::vector<Stem> away;
  for (const Stem& m : more) {
    const bool near = std::ranges::any_of(found, [&](const Stem& f) {
      return (m.centre_xy - f.centre_xy).norm() - 0.5 * (m.dbh_m + f.dbh_m) < gap_m;
    });
    if (near) continue;
    away.push_back(m);
    away.back().alternatives.clear();
    away.back().larger_cloud_part.clear();
  }
  std::ranges::stable_sort(away, NearerTheCentre);
  return away;
}

bool FitCircle(const std::vector<Eigen::Vector2d>& pts, Eigen::Vector2d* centre, double* radius,
               double* rms_m) {
  const int n = static_cast<int>(pts.size());
  if (n < 3) return false;
  // Kasa: x^2 + y^2 + D x + E y + F = 0, linear least squares.
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    a(i, 0) = pts[i].x();
    a(i, 1) = pts[i].y();
    a(i, 2) = 1.0;
    b(i) = -pts[i].squaredNorm();
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  Eigen::Vector2d c(-s(0) / 2, -s(1) / 2);
  double r2 = c.squaredNorm() - s(2);
  if (!(r2 > 0)) return false;
  double r = std::sqrt(r2);
  // Gauss-Newton on the geometric distance with Huber weights (5 mm).
  for (int it = 0; it < 10; ++it) {
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (const Eigen::Vector2d& p : pts) {
      const Eigen::Vector2d d = p - c;
      const double dist = d.norm();
      if (dist < 1e-9) continue;
      const double e = dist - r;
      const double w = std::abs(e) < 0.005 ? 1.0 : 0.005 / std::abs(e);
      const Eigen::Vector3d j(-d.x() / dist, -d.y() / dist, -1.0);
      h += w * j * j.transpose();
      g += w * j * e;
    }
    const Eigen::Vector3d step = h.ldlt().solve(-g);
    if (!step.allFinite()) break;
    c += step.head<2>();
    r += step(2);
    if (step.norm() < 1e-6) break;
  }
  double sq = 0;
  for (const Eigen::Vector2d& p : pts) sq += std::pow((p - c).norm() - r, 2);
  *centre = c;
  *radius = r;
  *rms_m = std::sqrt(sq / n);
  return r > 0 && std::isfinite(r);
}

namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = static_cast<size_t>(q * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// The paper's estimator: the slice seen from the plot centre, its robust width across the view.
double SliceWidth(const std::vector<Eigen::Vector2d>& pts, const Eigen::Vector2d& centre) {
  const Eigen::Vector2d u = centre.normalized();
  const Eigen::Vector2d across(-u.y(), u.x());
  std::vector<double> s;
  for (const Eigen::Vector2d& p : pts) s.push_back(across.dot(p - centre));
  return Quantile(s, 0.97) - Quantile(s, 0.03);
}

}  // namespace

double PassThroughRatio(const std::vector<const dense::CloudPoint*>& band, const Eigen::Vector2d& c,
                        double r, int* hits_out) {
  int through = 0, hits = 0;
  const double inner = 0.7 * r;
  for (const dense::CloudPoint* p : band) {
    const Eigen::Vector2d o = p->origin.head<2>().cast<double>();
    const Eigen::Vector2d e = p->world.head<2>().cast<double>();
    const Eigen::Vector2d d = e - o;
    const double len = d.norm();
    if (len < 1e-6) continue;
    const Eigen::Vector2d u = d / len;
    const double t = u.dot(c - o);  // closest approach along the ray
    if (t < 0) continue;
    const double miss = (o + t * u - c).norm();
    if ((e - c).norm() < r + 0.05) {
      ++hits;
    } else if (miss < inner && len > t + r + 0.1) {
      ++through;
    }
  }
  if (hits_out != nullptr) *hits_out = hits;
  return hits + through > 0 ? static_cast<double>(through) / (hits + through) : 1.0;
}

std::vector<const dense::CloudPoint*> BandPoints(const StemOptions& o,
                                                 const std::vector<dense::CloudPoint>& cloud,
                                                 const GroundGrid& ground,
                                                 std::vector<double>* height_m) {
  std::vector<const dense::CloudPoint*> band;
  for (const dense::CloudPoint& p : cloud) {
    const double x = p.world.x(), y = p.world.y();
    if (std::hypot(x, y) > o.search_radius_m) continue;
    const double h = p.world.z() - ground.FloorHeight(x, y);
    if (h < o.band_low_m || h > o.band_high_m) continue;
    band.push_back(&p);
    if (height_m != nullptr) height_m->push_back(h);
  }
  return band;
}

namespace {

// Connected parts of the occupancy grid of the given band points, cells with >= min_count points.
std::vector<std::vector<int>> SplitIntoParts(const StemOptions& o,
                                             const std::vector<const dense::CloudPoint*>& band,
                                             const std::vector<int>& idx, int min_count) {
  if (idx.empty()) return {};
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (int i : idx) {
    x0 = std::min<double>(x0, band[i]->world.x());
    y0 = std::min<double>(y0, band[i]->world.y());
    x1 = std::max<double>(x1, band[i]->world.x());
    y1 = std::max<double>(y1, band[i]->world.y());
  }
  const int w = static_cast<int>((x1 - x0) / o.grid_m) + 3,
            h = static_cast<int>((y1 - y0) / o.grid_m) + 3;
  auto cell_of = [&](int i) {
    return cv::Point(static_cast<int>((band[i]->world.x() - x0) / o.grid_m) + 1,
                     static_cast<int>((band[i]->world.y() - y0) / o.grid_m) + 1);
  };
  cv::Mat count(h, w, CV_32S, cv::Scalar(0));
  for (int i : idx) ++count.at<int>(cell_of(i));
  cv::Mat mask = count >= min_count, labels;
  cv::dilate(mask, mask, cv::Mat::ones(3, 3, CV_8U));
  const int n_labels = cv::connectedComponents(mask, labels, 8, CV_32S);
  std::vector<std::vector<int>> parts(std::max(0, n_labels - 1));
  for (int i : idx) {
    const cv::Point c = cell_of(i);
    // Points in sparse cells only join a part their cell was dilated into.
    const int l = labels.at<int>(c);
    if (l > 0) parts[l - 1].push_back(i);
  }
  return parts;
}

bool IsTooWide(const StemOptions& o, const std::vector<const dense::CloudPoint*>& band,
               const std::vector<int>& part) {
  std::vector<Eigen::Vector2d> xy;
  for (int i : part) xy.push_back(band[i]->world.head<2>().cast<double>());
  Eigen::Vector2d c;
  double r = 0, rms = 0;
  return !FitCircle(xy, &c, &r, &rms) || 2 * r > o.max_diameter_m;
}

// Centre and radius of a stem from its points' width across the line of sight from the plot
// centre (5th to 95th percentile) and their median range (the front face); `along_m` is their
// spread along it (5th to 95th percentile).
void AcrossWidthCircle(const std::vector<Eigen::Vector2d>& xy, Eigen::Vector2d* centre,
                       double* radius, double* along_m = nullptr) {
  std::vector<double> ranges, bearings;
  for (const Eigen::Vector2d& p : xy) {
    ranges.push_back(p.norm());
    bearings.push_back(std::atan2(p.y(), p.x()));
  }
  const double bearing0 = bearings[0];
  for (double& b : bearings) b = bearing0 + std::remainder(b - bearing0, 2 * M_PI);
  auto percentile = [](std::vector<double> v, double q) {
    const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[k];
  };
  const double range = percentile(ranges, 0.5);
  if (along_m) *along_m = percentile(ranges, 0.95) - percentile(ranges, 0.05);
  const double lo = percentile(bearings, 0.05), hi = percentile(bearings, 0.95);
  *radius = 0.5 * range * (hi - lo);
  const double mid = 0.5 * (lo + hi);
  *centre = (range + *radius) * Eigen::Vector2d(std::cos(mid), std::sin(mid));
}

// Stereo smears a far stem along the line of sight (depth is coarse, bearing fine), so a part too
// wide for one stem is split where its bearings from the centre leave a gap, then each bearing
// run where its ranges leave one (a stem behind another).
std::vector<std::vector<int>> SplitByBearing(const StemOptions& o,
                                             const std::vector<const dense::CloudPoint*>& band,
                                             const std::vector<int>& part) {
  std::vector<std::pair<double, int>> by_bearing;
  for (int i : part) {
    by_bearing.emplace_back(std::atan2(band[i]->world.y(), band[i]->world.x()), i);
  }
  std::sort(by_bearing.begin(), by_bearing.end());
  // Bearings wrap at ±180°: start after the widest gap.
  size_t start = 0;
  double widest = 0;
  for (size_t k = 0; k < by_bearing.size(); ++k) {
    const size_t prev = (k + by_bearing.size() - 1) % by_bearing.size();
    double gap = by_bearing[k].first - by_bearing[prev].first;
    if (gap < 0) gap += 2 * M_PI;
    if (gap > widest) widest = gap, start = k;
  }
  std::vector<std::vector<int>> runs(1);
  for (size_t n = 0; n < by_bearing.size(); ++n) {
    const size_t k = (start + n) % by_bearing.size();
    const double range =
        std::hypot(band[by_bearing[k].second]->world.x(), band[by_bearing[k].second]->world.y());
    if (n > 0) {
      const size_t prev = (k + by_bearing.size() - 1) % by_bearing.size();
      double gap = by_bearing[k].first - by_bearing[prev].first;
      if (gap < 0) gap += 2 * M_PI;
      if (gap * range > o.split_gap_m) runs.emplace_back();
    }
    runs.back().push_back(by_bearing[k].second);
  }
  std::vector<std::vector<int>> out;
  for (std::vector<int>& run : runs) {
    std::vector<std::pair<double, int>> by_range;
    for (int i : run) by_range.emplace_back(band[i]->world.head<2>().norm(), i);
    std::sort(by_range.begin(), by_range.end());
    out.emplace_back();
    for (size_t k = 0; k < by_range.size(); ++k) {
      if (k > 0 && by_range[k].first - by_range[k - 1].first > o.split_range_gap_m) {
        out.emplace_back();
      }
      out.back().push_back(by_range[k].second);
    }
  }
  return out;
}

// The band's points with their heights above the ground.
struct Band {
  const std::vector<const dense::CloudPoint*>& points;
  const std::vector<double>& height_m;
};

// The centre of the circle of radius r through `pts` (robust least squares on the distances,
// from c0: points off it by more than a third of r, smeared or stray, weigh less), and the
// median of their distances from it.
Eigen::Vector2d CentreOfCircle(const std::vector<Eigen::Vector2d>& pts, double r,
                               Eigen::Vector2d c0, double* median_off_m) {
  const double huber_m = r / 3;
  for (int it = 0; it < 10; ++it) {
    // Gauss-Newton on e_i = |p_i - c| - r, whose gradient in c is -(p_i - c) / |p_i - c|.
    Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
    Eigen::Vector2d jte = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : pts) {
      const Eigen::Vector2d d = p - c0;
      const double n = d.norm();
      if (n < 1e-9) continue;
      const double e = n - r, w = std::abs(e) < huber_m ? 1.0 : huber_m / std::abs(e);
      const Eigen::Vector2d j = -d / n;
      jtj += w * j * j.transpose();
      jte += w * j * e;
    }
    if (std::abs(jtj.determinant()) < 1e-12) break;
    const Eigen::Vector2d step = -jtj.ldlt().solve(jte);
    c0 += step;
    if (step.norm() < 1e-5) break;
  }
  std::vector<double> off;
  for (const Eigen::Vector2d& p : pts) off.push_back(std::abs((p - c0).norm() - r));
  *median_off_m = off.empty() ? 0.0 : Quantile(off, 0.5);
  return c0;
}

// Why a part of the band is no stem.
enum class Rejection : uint8_t { kNone, kWidth, kLean, kSurface, kFreeSpace };

// One part of the band as a stem: centre, widths, lean and support; nullopt (counted in `tally`,
// the reason in `why` where given) when it is no stem. A `smeared` part is measured across the
// line of sight whatever its spread along it (a core of a smeared part: its depth is as noisy as
// the whole's). A part the free-space veto rejects goes to `vetoed` where that is given.
std::optional<Stem> MeasurePart(const StemOptions& o, const Band& b, const std::vector<int>& m,
                                const GroundGrid& ground, double depth_focal_px, bool smeared,
                                StemsResult* tally, std::vector<Stem>* vetoed = nullptr,
                                Rejection* why = nullptr) {
  auto reject = [&](Rejection r) {
    if (why) *why = r;
    return std::nullopt;
  };
  std::vector<Eigen::Vector2d> all_xy;
  for (int i : m) all_xy.push_back(b.points[i]->world.head<2>().cast<double>());
  Eigen::Vector2d c0;
  double r0 = 0, rms0 = 0;
  // A far stem's points are smeared along the line of sight (more than a trunk's face is deep),
  // and a circle through them means nothing; its width across the line of sight still does.
  Eigen::Vector2d c_across;
  double r_across = 0, along_m = 0;
  AcrossWidthCircle(all_xy, &c_across, &r_across, &along_m);
  const bool circle_ok = !smeared && along_m < 2 * r_across + o.max_depth_smear_m &&
                         FitCircle(all_xy, &c0, &r0, &rms0) && 2 * r0 >= o.min_diameter_m &&
                         2 * r0 <= o.max_diameter_m;
  if (!circle_ok) c0 = c_across, r0 = r_across;
  if (2 * r0 < o.min_diameter_m || 2 * r0 > o.max_diameter_m) {
    ++tally->rejected_size;
    spdlog::debug(
        "stems: part of {} points at ({:.2f}, {:.2f}) rejected: diameter {:.2f} m (ground "
        "{:.2f})",
        m.size(), c0.x(), c0.y(), 2 * r0, ground.Height(c0.x(), c0.y()));
    return reject(Rejection::kWidth);
  }
  // Verticality: centroids of three sub-slices of the band on one near-vertical line. Only
  // points near the stem's circle count: clutter joined to the part at one height (smeared
  // edges of a near trunk, a branch) would drag that sub-slice's centroid away.
  // A sub-slice with a tenth of the best one's points holds no surface, only stray points (a
  // near stem's top is out of view).
  const double third = (o.band_high_m - o.band_low_m) / 3;
  const double core_m = r0 + 0.25;
  std::array<Eigen::Vector3d, 3> sum;
  std::array<int, 3> cnt = {0, 0, 0};
  std::array<std::vector<Eigen::Vector2d>, 3> slice_xy;
  sum.fill(Eigen::Vector3d::Zero());
  for (int i : m) {
    const Eigen::Vector2d xy(b.points[i]->world.x(), b.points[i]->world.y());
    const int s = static_cast<int>(std::floor((b.height_m[i] - o.band_low_m) / third));
    if ((xy - c0).norm() > core_m || s < 0 || s > 2) continue;
    sum[s] += Eigen::Vector3d(xy.x(), xy.y(), b.height_m[i]);
    slice_xy[s].push_back(xy);
    ++cnt[s];
  }
  const int most = *std::ranges::max_element(cnt);
  std::vector<Eigen::Vector3d> cent;
  for (int s = 0; s < 3; ++s) {
    if (cnt[s] >= o.lean_slice_min_points && cnt[s] + 1e-9 >= o.lean_slice_min_share * most) {
      cent.push_back(sum[s] / cnt[s]);
      // Each third's centre is the stem's circle placed on its points: a near trunk shows each
      // height from other arm positions (the frame's bottom edge cuts the lower bark from the
      // nearest ones), so the arcs differ, and their centroids with them, by most of its radius.
      // Started behind the arc's centroid, away from the cameras near the plot centre (a
      // circle of a given radius fits an arc from either side). Where the third's points lie on
      // it (a far stem's are smeared along the line of sight), it replaces the centroid.
      const Eigen::Vector2d centroid = cent.back().head<2>();
      double off_m = 0.0;
      const Eigen::Vector2d centre =
          CentreOfCircle(slice_xy[s], r0, centroid + 0.64 * r0 * centroid.normalized(), &off_m);
      if (off_m < o.lean_circle_max_off_share * r0) cent.back().head<2>() = centre;
    }
  }
  double lean_deg = 90.0;
  if (cent.size() >= 2) {
    const Eigen::Vector3d d = cent.back() - cent.front();
    lean_deg = std::atan2(d.head<2>().norm(), std::abs(d.z())) * 180.0 / M_PI;
  }
  if (lean_deg > o.max_lean_deg) {
    ++tally->rejected_vertical;
    spdlog::debug(
        "stems: part at ({:.2f}, {:.2f}) rejected: lean {:.1f}° ({} sub-slices of "
        "{}/{}/{} points{})",
        c0.x(), c0.y(), lean_deg, cent.size(), cnt[0], cnt[1], cnt[2],
        cent.size() >= 2 ? fmt::format(", ({:.2f}, {:.2f}, {:.2f}) to ({:.2f}, {:.2f}, "
                                       "{:.2f})",
                                       cent.front().x(), cent.front().y(), cent.front().z(),
                                       cent.back().x(), cent.back().y(), cent.back().z())
                         : "");
    return reject(Rejection::kLean);
  }
  // Breast-height slice.
  std::vector<Eigen::Vector2d> slice;
  std::set<int> views;
  double half = o.slice_half_m;
  for (int widen = 0; widen < 3 && slice.size() < 15; ++widen, half *= 2) {
    slice.clear();
    views.clear();
    for (int i : m) {
      if (std::abs(b.height_m[i] - o.breast_height_m) > half) continue;
      slice.push_back(b.points[i]->world.head<2>().cast<double>());
      views.insert(b.points[i]->keyframe);
    }
  }
  if (slice.size() < 8) return reject(Rejection::kSurface);
  const double support_m2 =
      depth_focal_px > 0 ? slice.size() * c0.squaredNorm() / (depth_focal_px * depth_focal_px)
                         : o.min_slice_support_m2;
  Stem s;
  if (support_m2 < o.min_slice_support_m2) {
    if (support_m2 < o.weak_support_share * o.min_slice_support_m2) {
      ++tally->rejected_size;
      spdlog::debug("stems: part at ({:.2f}, {:.2f}) rejected: {} slice points", c0.x(), c0.y(),
                    slice.size());
      return reject(Rejection::kSurface);
    }
    s.weak_support = true;
  }
  double r = r0, rms = rms0;
  Eigen::Vector2d c = c0;
  // The slice is a thin arc of the stem's face, and a circle fit to it can settle on a much
  // larger circle bulging the other way (its centre in front of the face): the band's circle
  // then stands.
  std::vector<double> slice_ranges;
  for (const Eigen::Vector2d& p : slice) slice_ranges.push_back(p.norm());
  const double face_m = Quantile(slice_ranges, 0.5);
  if (!FitCircle(slice, &c, &r, &rms) || 2 * r > o.max_diameter_m || c.norm() < face_m) {
    c = c0;
    r = r0;
    rms = rms0;
  }
  s.dbh_circle_m = 2 * r;
  s.dbh_slice_m = SliceWidth(slice, c);
  if (!circle_ok) {
    AcrossWidthCircle(slice, &c, &r);
    s.dbh_circle_m = s.dbh_slice_m = 2 * r;
    s.depth_smeared = true;
    // No circle to spread about: the width rests on its outermost bearings, each good to about
    // a depth pixel at that range.
    rms = depth_focal_px > 0 ? c.norm() / depth_focal_px : 0.0;
  }
  s.pass_through = PassThroughRatio(b.points, c, r);
  s.centre_xy = c;
  s.face_range_m = face_m;
  s.slice_xy = slice;
  s.ground_z_m = ground.UphillHeight(c.x(), c.y(), r);
  s.floor_z_m = ground.FloorHeight(c.x(), c.y());
  s.dbh_m = o.dbh_method == DbhMethod::kCircle ? s.dbh_circle_m : s.dbh_slice_m;  // tangent: later
  s.dbh_sd_m = rms;
  s.n_points = static_cast<int>(slice.size());
  s.n_views = static_cast<int>(views.size());
  s.lean_deg = lean_deg;
  if (lean_deg > o.confirm_lean_deg) s.weak_support = true;
  if (s.n_views < 3) s.flags.Set(StemFlag::kFewViews);
  if (s.pass_through > o.free_space_veto) {
    ++tally->vetoed_free_space;
    spdlog::debug("stems: part at ({:.2f}, {:.2f}) vetoed: {:.0f}% of rays pass through", c.x(),
                  c.y(), 100 * s.pass_through);
    if (vetoed) {
      s.weak_support = true;
      vetoed->push_back(std::move(s));
    }
    return reject(Rejection::kFreeSpace);
  }
  return s;
}

// A part split again on denser cells: stems one behind another that depth noise joined, or a
// stem and a sapling beside it, stand out as dense cores. A core still smeared is split again on
// denser cells still. Empty when no density splits the part in two or more, unless one core
// alone holds at most lone_core_max_share of its points (what it shed leaned or widened it).
std::vector<std::vector<int>> SplitOnDenserCells(const StemOptions& o,
                                                 const std::vector<const dense::CloudPoint*>& band,
                                                 const std::vector<int>& part, int min_count,
                                                 double lone_core_max_share = 0.0) {
  for (; min_count <= 32 * o.min_cell_points; min_count *= 2) {
    std::vector<std::vector<int>> subs;
    for (std::vector<int>& sub : SplitIntoParts(o, band, part, min_count)) {
      if (static_cast<int>(sub.size()) >= o.min_points) subs.push_back(std::move(sub));
    }
    if (subs.empty()) break;
    if (subs.size() < 2) {
      if (subs[0].size() <= lone_core_max_share * part.size()) return subs;
      continue;
    }
    std::vector<std::vector<int>> cores;
    for (std::vector<int>& sub : subs) {
      std::vector<Eigen::Vector2d> xy;
      for (int i : sub) xy.push_back(band[i]->world.head<2>().cast<double>());
      Eigen::Vector2d c;
      double r = 0, along_m = 0;
      AcrossWidthCircle(xy, &c, &r, &along_m);
      std::vector<std::vector<int>> finer;
      if (along_m > 2 * r + o.max_depth_smear_m) {
        finer = SplitOnDenserCells(o, band, sub, 2 * min_count);
      }
      if (finer.empty()) {
        cores.push_back(std::move(sub));
      } else {
        for (std::vector<int>& f : finer) cores.push_back(std::move(f));
      }
    }
    return cores;
  }
  return {};
}

// A part no stem as a whole, too wide for one or leaning far (a stem with a shrub beside it at
// one height, stems in a shrub, a clump of stems that understory joins): each of its denser
// cores that measures as a stem is one, on weak support, so that only silhouettes confirm it (a
// shrub's dense core has none). A core no stem for the same reasons is split again on denser
// cells.
void AddCoresOfAMixedPart(const StemOptions& o, const Band& b, const std::vector<int>& m,
                          int min_count, const GroundGrid& ground, double depth_focal_px,
                          StemsResult* result) {
  StemsResult not_counted;
  for (const std::vector<int>& sub :
       SplitOnDenserCells(o, b.points, m, min_count, o.mixed_part_lone_core_max_share)) {
    Rejection why = Rejection::kNone;
    std::optional<Stem> a =
        MeasurePart(o, b, sub, ground, depth_focal_px, false, &not_counted, nullptr, &why);
    if (!a) {
      if (why == Rejection::kWidth || why == Rejection::kLean) {
        AddCoresOfAMixedPart(o, b, sub, 2 * min_count, ground, depth_focal_px, result);
      }
      continue;
    }
    a->weak_support = true;
    a->mixed_part_core = true;
    ++result->mixed_part_cores;
    spdlog::debug("stems: core ({:.2f}, {:.2f}) {:.3f} m of a part no stem as a whole",
                  a->centre_xy.x(), a->centre_xy.y(), a->dbh_m);
    result->stems.push_back(std::move(*a));
  }
}

}  // namespace

StemsResult DetectStems(const StemOptions& o, const std::vector<dense::CloudPoint>& cloud,
                        const GroundGrid& ground, double depth_focal_px) {
  o.Check();
  StemsResult result;
  // Points of the detection band, with their height above the ground.
  std::vector<double> band_h;
  const std::vector<const dense::CloudPoint*> band = BandPoints(o, cloud, ground, &band_h);
  // Parts of the band: connected occupied cells. A part too wide to be one stem (two trunks
  // smeared together by depth noise) is split again on its denser cells.
  std::vector<std::vector<int>> parts;
  // A learned trunk mask, where there is one, keeps other surfaces out of the parts; the free-space
  // veto still sees every ray.
  std::vector<int> all;
  for (size_t i = 0; i < band.size(); ++i) {
    if (band[i]->trunk != 0) all.push_back(static_cast<int>(i));
  }
  std::vector<std::pair<std::vector<int>, int>> queue = {{all, o.min_cell_points}};
  while (!queue.empty()) {
    auto [idx, min_count] = std::move(queue.back());
    queue.pop_back();
    for (std::vector<int>& part : SplitIntoParts(o, band, idx, min_count)) {
      if (static_cast<int>(part.size()) < o.min_points) continue;
      if (o.split_wide_parts && min_count < 8 * o.min_cell_points && IsTooWide(o, band, part)) {
        queue.emplace_back(std::move(part), 2 * min_count);
      } else if (o.split_by_bearing && IsTooWide(o, band, part)) {
        for (std::vector<int>& sub : SplitByBearing(o, band, part)) {
          if (static_cast<int>(sub.size()) >= o.min_points) parts.push_back(std::move(sub));
        }
      } else {
        parts.push_back(std::move(part));
      }
    }
  }
  result.components = static_cast<int>(parts.size());
  const Band b{band, band_h};
  for (const std::vector<int>& m : parts) {
    Rejection why = Rejection::kNone;
    std::optional<Stem> s =
        MeasurePart(o, b, m, ground, depth_focal_px, false, &result, &result.vetoed, &why);
    if (o.split_mixed_parts_into_cores && (why == Rejection::kWidth || why == Rejection::kLean)) {
      AddCoresOfAMixedPart(o, b, m, 2 * o.min_cell_points, ground, depth_focal_px, &result);
    }
    if (!s) continue;
    if (o.split_parts_into_cores) {
      // Every core that is a stem on its own, even one alone: its siblings may be no stem (a
      // sapling too thin, a clump of leaves at one height) while the part, widened by them, fits
      // no silhouette as a whole.
      StemsResult not_counted;
      for (const std::vector<int>& sub : SplitOnDenserCells(o, band, m, 2 * o.min_cell_points)) {
        std::optional<Stem> a =
            MeasurePart(o, b, sub, ground, depth_focal_px, s->depth_smeared, &not_counted);
        if (a) s->alternatives.push_back(std::move(*a));
      }
    }
    result.stems.push_back(std::move(*s));
  }
  std::sort(result.stems.begin(), result.stems.end(), NearerTheCentre);
  return result;
}

}  // namespace stemmap::stems
