#include "stemmap/stems/bark_depth.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

#include "stemmap/core/error.h"
#include "stemmap/stems/silhouette.h"

namespace stemmap::stems {

void BarkDepthOptions::Check() const {
  if (!(baseline_m > 0.05 && baseline_m < 2.0))
    throw InputError("bark baseline must be in (0.05, 2) m");
  if (!(min_baseline_m > 0 && min_baseline_m <= baseline_m)) {
    throw InputError("the shortest bark baseline must be positive and at most the baseline");
  }
  if (!(baseline_share >= 0 && baseline_share < 0.2))
    throw InputError("bark baseline share must be in [0, 0.2)");
  if (!(band_half_height_m > 0.01 && band_half_height_m < 0.5)) {
    throw InputError("bark band half height must be in (0.01, 0.5) m");
  }
  if (!(inner_share > 0.1 && inner_share <= 1.0))
    throw InputError("bark inner share must be in (0.1, 1]");
  if (!(search_m > 0 && step_m > 0 && search_m / step_m <= 500)) {
    throw InputError("bark depth search: search_m and step_m positive, at most 500 steps");
  }
  if (max_pixels < min_pixels || min_pixels < 10) throw InputError("bark pixel counts invalid");
  if (!(min_surface_ncc <= min_peak_ncc)) {
    throw InputError("the bark's surface correlation must not exceed its peak correlation");
  }
  if (min_pairs < 2) throw InputError("bark depth needs at least 2 pairs");
  if (!(max_hidden_view_share >= 0 && max_hidden_view_share < 1)) {
    throw InputError("the share of views leaves may hide from the bark must lie in [0, 1)");
  }
  if (!(rim_gap_share >= 0 && rim_outer_share > rim_gap_share && rim_outer_share <= 1)) {
    throw InputError(
        "the bark's rim must reach from a share of the width at least 0 up to one greater, at "
        "most 1");
  }
}

namespace {

// The columns of a stem's width compared, as shares of its apparent width about its middle: the
// middle `outer_share` (plain bark), less the middle `hollow_share` (the rim of a circle beyond a
// narrower one inside it).
struct ColumnWindow {
  double hollow_share = 0.0;
  double outer_share = 0.6;
};

// What keyframe k shows of a stem's bark at breast height: the stretches of columns compared and
// the nearer stems' columns, where nothing of the stem shows. Without a hollow, the widest
// stretch of the window that nearer stems leave free, if at least three quarters of it; with
// one, every free stretch of the two sides, if together three quarters of them.
struct BarkView {
  bool sees = false;
  std::vector<std::array<double, 2>> cols;
  std::vector<std::array<double, 2>> occluder_cols;
  bool Hidden(double x) const {
    return std::ranges::any_of(occluder_cols, [&](const auto& q) { return x > q[0] && x < q[1]; });
  }
};

BarkView SeesBark(const TangentOptions& t, const TangentViews& v, int k, const Eigen::Vector2d& c,
                  double r, double breast_z, const ColumnWindow& window) {
  BarkView out;
  if (k < 0 || k >= static_cast<int>(v.keyframes->size()) || (*v.gray)[k].empty()) return out;
  const PinholeCamera& cam = *v.camera;
  const Rigid3d& world_from_cam = (*v.keyframes)[k].world_from_cam;
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  const Eigen::Vector2d cc = world_from_cam.translation.head<2>();
  if (!StemInView(cam, cam_from_world, cc, c, r, breast_z)) return out;
  const double d = (c - cc).norm();
  std::array<double, 2> xs;
  if (!SilhouetteColumns(cam, cam_from_world, cc, c, r, breast_z, &xs)) return out;
  const double xm = 0.5 * (xs[0] + xs[1]), half = 0.5 * window.outer_share * (xs[1] - xs[0]);
  const double hollow = 0.5 * window.hollow_share * (xs[1] - xs[0]);
  std::vector<std::array<double, 2>> free;
  if (hollow > 0) {
    free = {{xm - half, xm - hollow}, {xm + hollow, xm + half}};
  } else {
    free = {{xm - half, xm + half}};
  }
  // Free stretches of the window, clear of each nearer stem by a tenth of the stem's width (the
  // nearer stem's fitted outline errs by a few pixels).
  const double guard_px = std::max(3.0, 0.1 * (xs[1] - xs[0]));
  for (const Eigen::Vector3d& q : FrontOccluders(t, v, cc, (c - cc) / d, d, r)) {
    std::array<double, 2> qs;
    if (!SilhouetteColumns(cam, cam_from_world, cc, q.head<2>(), q.z(), breast_z, &qs)) continue;
    const double ql = qs[0] - guard_px, qr = qs[1] + guard_px;
    out.occluder_cols.push_back({ql, qr});
    std::vector<std::array<double, 2>> rest;
    for (const auto& [lo, hi] : free) {
      if (ql > lo) rest.push_back({lo, std::min(hi, ql)});
      if (qr < hi) rest.push_back({std::max(lo, qr), hi});
    }
    free = std::move(rest);
  }
  const double window_px = 2 * (half - hollow);
  if (hollow > 0) {
    double width = 0;
    for (const auto& [lo, hi] : free) {
      if (hi - lo < 1.0) continue;
      out.cols.push_back({lo, hi});
      width += hi - lo;
    }
    out.sees = width >= std::max(4.0, 0.75 * window_px);
    return out;
  }
  std::array<double, 2> widest = {0, 0};
  for (const auto& [lo, hi] : free) {
    if (hi - lo > widest[1] - widest[0]) widest = {lo, hi};
  }
  out.cols = {widest};
  out.sees = widest[1] - widest[0] >= std::max(4.0, 0.75 * window_px);
  return out;
}

// Views where something stands in front of the stem's bark (a sapling's crown, leaves, a shrub):
// every pair a view is in stays below min_surface_ncc at every distance. Those views are left out
// when they are at most max_hidden_view_share of the views compared; more, and the circle's inside
// is no one stem's bark, and no view is left out.
std::vector<char> ViewsHiddenFromTheBark(const BarkDepthOptions& o,
                                         const std::vector<std::array<int, 2>>& pairs,
                                         const std::vector<std::vector<double>>& ncc,
                                         const std::vector<char>& complete, int n_kf) {
  std::vector<double> best(n_kf, -2.0);  // per view, the best correlation of its pairs
  std::vector<char> compared(n_kf, 0);
  for (size_t p = 0; p < pairs.size(); ++p) {
    if (!complete[p]) continue;
    const double peak = *std::ranges::max_element(ncc[p]);
    for (int k : pairs[p]) best[k] = std::max(best[k], peak), compared[k] = 1;
  }
  std::vector<char> hidden(n_kf, 0);
  int n_compared = 0, n_hidden = 0;
  for (int k = 0; k < n_kf; ++k) {
    if (!compared[k]) continue;
    ++n_compared;
    hidden[k] = best[k] < o.min_surface_ncc;
    n_hidden += hidden[k];
  }
  if (n_hidden > o.max_hidden_view_share * n_compared) std::ranges::fill(hidden, 0);
  return hidden;
}

// The bark in `window` of the circle's width, as MeasureBarkDepth says.
BarkDepth MeasureBarkIn(const BarkDepthOptions& o, const TangentOptions& t, const TangentViews& v,
                        const Eigen::Vector2d& c, double r, double breast_z,
                        const ColumnWindow& window) {
  BarkDepth out;
  const double dist = c.norm();
  if (!o.enabled || dist < 1e-6 || r <= 0) return out;
  const Eigen::Vector2d along = c / dist;
  const PinholeCamera& cam = *v.camera;
  const int n_kf = static_cast<int>(v.keyframes->size());
  // Pairs (k, j): k's bark pixels are warped into j.
  std::vector<std::array<int, 2>> pairs;
  const double baseline_m = std::max(o.baseline_m, o.baseline_share * dist);
  std::vector<BarkView> seen(n_kf);
  for (int k = 0; k < n_kf; ++k) seen[k] = SeesBark(t, v, k, c, r, breast_z, window);
  double cam_dist_sum = 0;
  int cam_dist_n = 0;
  for (int k = 0; k < n_kf; ++k) {
    if (!seen[k].sees) continue;
    const Eigen::Vector3d ck = (*v.keyframes)[k].world_from_cam.translation;
    cam_dist_sum += (c - ck.head<2>()).norm();
    ++cam_dist_n;
    const auto apart = [&](int i) {
      return ((*v.keyframes)[i].world_from_cam.translation - ck).head<2>().norm();
    };
    for (int dir : {-1, 1}) {
      int j = k + dir;
      while (j >= 0 && j < n_kf && apart(j) < baseline_m) j += dir;
      // Short of the baseline where the bark is hidden or out of the picture there, down to
      // the shortest baseline.
      j = std::clamp(j, 0, n_kf - 1);
      while (j != k && !(seen[j].sees && apart(j) >= o.min_baseline_m)) j -= dir;
      if (j != k) pairs.push_back({k, j});
    }
  }
  if (static_cast<int>(pairs.size()) < o.min_pairs) {
    spdlog::debug("bark depth ({:.2f}, {:.2f}) r {:.3f}: {} views see the bark, {} pairs", c.x(),
                  c.y(), r, cam_dist_n, pairs.size());
    return out;
  }
  // The radius scales with the distance from the cameras, which keeps the apparent width.
  const double cam_dist = cam_dist_sum / cam_dist_n;
  const int n_steps = 2 * static_cast<int>(std::lround(o.search_m / o.step_m)) + 1;
  const int half = n_steps / 2;
  std::vector<std::vector<double>> ncc(pairs.size(), std::vector<double>(n_steps, NAN));
#pragma omp parallel for schedule(dynamic)
  for (size_t p = 0; p < pairs.size(); ++p) {
    const auto [k, j] = pairs[p];
    const cv::Mat& img_k = (*v.gray)[k];
    const cv::Mat& img_j = (*v.gray)[j];
    const Rigid3d& world_from_k = (*v.keyframes)[k].world_from_cam;
    const Rigid3d j_from_world = (*v.keyframes)[j].world_from_cam.Inverse();
    const Rigid3d k_from_world = world_from_k.Inverse();
    // Rotations as matrices: a quaternion costs twice the multiplications per pixel.
    const Eigen::Matrix3d world_from_k_rotation = world_from_k.rotation.toRotationMatrix();
    const Eigen::Matrix3d j_from_world_rotation = j_from_world.rotation.toRotationMatrix();
    const Eigen::Vector3d ck = world_from_k.translation;
    // k's bark: the window's free columns, rows within the band around breast height.
    const double y_top =
        cam.ImageFromCam(k_from_world *
                         Eigen::Vector3d(c.x(), c.y(), breast_z + o.band_half_height_m))
            .y();
    const double y_bot =
        cam.ImageFromCam(k_from_world *
                         Eigen::Vector3d(c.x(), c.y(), breast_z - o.band_half_height_m))
            .y();
    const int y0 = std::max(1, static_cast<int>(std::ceil(std::min(y_top, y_bot))));
    const int y1 = std::min(img_k.rows - 2, static_cast<int>(std::floor(std::max(y_top, y_bot))));
    std::vector<std::array<int, 2>> xr;
    double width = 0;
    for (const auto& [lo, hi] : seen[k].cols) {
      const int x0 = std::max(1, static_cast<int>(std::ceil(lo)));
      const int x1 = std::min(img_k.cols - 2, static_cast<int>(std::floor(hi)));
      if (x1 < x0) continue;
      xr.push_back({x0, x1});
      width += x1 - x0 + 1;
    }
    const double area = width * std::max(0, y1 - y0 + 1);
    if (area < o.min_pixels) continue;
    const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(area / o.max_pixels))));
    std::vector<Eigen::Vector3d> rays;
    std::vector<float> values;
    std::vector<int> stretch;
    for (int y = y0; y <= y1; y += stride) {
      for (size_t i = 0; i < xr.size(); ++i) {
        for (int x = xr[i][0]; x <= xr[i][1]; x += stride) {
          rays.push_back(world_from_k_rotation * cam.CamRayFromImage({double(x), double(y)}));
          values.push_back(img_k.at<uchar>(y, x));
          stretch.push_back(static_cast<int>(i));
        }
      }
    }
    // The correlation of k's bark with j's pixels where `in_j` (a bark pixel's index) puts it:
    // each stretch of columns on its own (the two sides of a rim differ in brightness, which
    // any warp keeping them apart would match), weighed by its pixels.
    auto correlate = [&](const auto& in_j) {
      struct Sums {
        double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
        int n = 0;
      };
      std::vector<Sums> sums(xr.size());
      int n = 0;
      for (size_t m = 0; m < rays.size(); ++m) {
        const std::optional<Eigen::Vector3d> p_j = in_j(m);
        if (!p_j || p_j->z() <= 0.1) continue;
        const Eigen::Vector2d px = cam.ImageFromCam(*p_j);
        if (seen[j].Hidden(px.x())) continue;
        const float vj = BilinearGray(img_j, px.x(), px.y());
        if (vj < 0) continue;
        const double va = values[m];
        Sums& t = sums[stretch[m]];
        t.sa += va, t.sb += vj, t.saa += va * va, t.sbb += double(vj) * vj, t.sab += va * vj;
        ++t.n;
        ++n;
      }
      if (n < o.min_pixels || 2 * n < static_cast<int>(rays.size())) return double(NAN);
      const auto ncc_of = [](const Sums& t) {
        const double cov = t.sab - t.sa * t.sb / t.n, var_a = t.saa - t.sa * t.sa / t.n,
                     var_b = t.sbb - t.sb * t.sb / t.n;
        if (t.n < 2 || var_a <= 1e-6 * t.n || var_b <= 1e-6 * t.n) return double(NAN);
        return cov / std::sqrt(var_a * var_b);
      };
      if (sums.size() == 1) return ncc_of(sums[0]);
      double weighted = 0;
      int weight = 0;
      for (const Sums& t : sums) {
        const double c = ncc_of(t);
        if (std::isnan(c)) continue;
        weighted += t.n * c;
        weight += t.n;
      }
      return 2 * weight < n ? double(NAN) : weighted / weight;
    };
    for (int i = 0; i < n_steps; ++i) {
      const double shift = (i - half) * o.step_m;
      const Eigen::Vector2d ci = c + shift * along;
      const double ri = r * (cam_dist + shift) / cam_dist;
      const Eigen::Vector2d q = ck.head<2>() - ci;
      ncc[p][i] = correlate([&](size_t m) -> std::optional<Eigen::Vector3d> {
        const Eigen::Vector3d& w = rays[m];
        const double a = w.head<2>().squaredNorm(), b = q.dot(w.head<2>());
        const double disc = b * b - a * (q.squaredNorm() - ri * ri);
        if (a < 1e-12 || disc < 0) return std::nullopt;
        const double s = (-b - std::sqrt(disc)) / a;
        if (s <= 0) return std::nullopt;
        return j_from_world_rotation * (ck + s * w) + j_from_world.translation;
      });
    }
  }
  // The mean over pairs that compared at every distance, so that each distance has the same pairs,
  // and that show the bark in both views.
  std::vector<char> complete(pairs.size());
  for (size_t p = 0; p < pairs.size(); ++p) {
    complete[p] = std::ranges::none_of(ncc[p], [](double x) { return std::isnan(x); });
  }
  const std::vector<char> hidden = ViewsHiddenFromTheBark(o, pairs, ncc, complete, n_kf);
  std::vector<double> score(n_steps, 0.0);
  for (size_t p = 0; p < pairs.size(); ++p) {
    if (!complete[p] || hidden[pairs[p][0]] || hidden[pairs[p][1]]) continue;
    for (int i = 0; i < n_steps; ++i) score[i] += ncc[p][i];
    ++out.pairs;
  }
  if (out.pairs < o.min_pairs) return out;
  for (double& s : score) s /= out.pairs;
  const int best = static_cast<int>(std::ranges::max_element(score) - score.begin());
  out.peak_ncc = score[best];
  out.end_ncc = 0.5 * (score.front() + score.back());
  spdlog::debug(
      "bark depth ({:.2f}, {:.2f}) r {:.3f}{}: {} pairs, peak {:.3f} at {:+.3f} m, ends {:.3f}",
      c.x(), c.y(), r,
      window.hollow_share > 0
          ? fmt::format(" (rim {:.2f}-{:.2f})", window.hollow_share, window.outer_share)
          : "",
      out.pairs, out.peak_ncc, (best - half) * o.step_m, out.end_ncc);
  out.at_search_end = best == 0 || best == n_steps - 1;
  if (out.at_search_end) return out;
  if (out.peak_ncc < o.min_peak_ncc || out.peak_ncc - out.end_ncc < o.min_peak_contrast) return out;
  const double sm = score[best - 1], sp = score[best + 1];
  const double den = sm - 2 * score[best] + sp;
  const double off = den < 0 ? std::clamp(0.5 * (sm - sp) / den, -0.5, 0.5) : 0.0;
  out.shift_m = (best - half + off) * o.step_m;
  out.scale = (cam_dist + out.shift_m) / cam_dist;
  out.ok = true;
  return out;
}

}  // namespace

BarkDepth MeasureBarkDepth(const BarkDepthOptions& o, const TangentOptions& t,
                           const TangentViews& v, const Eigen::Vector2d& c, double r,
                           double breast_z) {
  return MeasureBarkIn(o, t, v, c, r, breast_z,
                       {.hollow_share = 0.0, .outer_share = o.inner_share});
}

BarkDepth MeasureRimBark(const BarkDepthOptions& o, const TangentOptions& t, const TangentViews& v,
                         const Eigen::Vector2d& c, double r, double inner_radius, double breast_z) {
  const double hollow = inner_radius / r + o.rim_gap_share;
  if (!(hollow > 0 && hollow < o.rim_outer_share)) return {};
  return MeasureBarkIn(o, t, v, c, r, breast_z,
                       {.hollow_share = hollow, .outer_share = o.rim_outer_share});
}

BarkVerdict JudgeBark(const BarkDepthOptions& o, const BarkDepth& bark) {
  if (bark.ok) return BarkVerdict::kLinesUp;
  if (bark.pairs >= o.min_pairs && (bark.peak_ncc < o.min_peak_ncc || bark.at_search_end)) {
    return BarkVerdict::kLinesUpNowhere;
  }
  return BarkVerdict::kSaysNothing;
}

}  // namespace stemmap::stems
