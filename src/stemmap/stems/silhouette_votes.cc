#include "stemmap/stems/silhouette_votes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>

#include "stemmap/core/error.h"
#include "stemmap/stems/silhouette.h"

namespace stemmap::stems {

void SilhouetteVoteOptions::Check() const {
  if (max_candidates < 0) throw InputError("the silhouette votes' candidates must not be negative");
  if (!(min_gap_to_listed_m >= 0)) {
    throw InputError("the silhouette votes' gap to a listed stem must not be negative");
  }
  if (!(cell_m > 0.005 && cell_m <= 0.5)) {
    throw InputError("the silhouette vote grid's cell must lie in (0.005, 0.5] m");
  }
  if (!(min_radius_m > 0 && max_radius_m >= min_radius_m && radius_step_m > 0)) {
    throw InputError("the silhouette votes' radii must be positive and ordered");
  }
  if (!(min_range_m >= 0))
    throw InputError("the silhouette votes' least range must not be negative");
  if (strip_rows < 2) throw InputError("the silhouette strip needs at least two rows");
  if (!(strip_half_height_m > 0 && strip_range_m > 0)) {
    throw InputError("the silhouette strip's height and range must be positive");
  }
  if (!(min_edge_step > 0)) throw InputError("the silhouette edge step must be positive");
  if (!(min_edge_straightness >= 0 && min_edge_straightness <= 1)) {
    throw InputError("the silhouette edge straightness must lie in [0, 1]");
  }
  if (!(neighbour_baseline_m > 0)) {
    throw InputError("the silhouette votes' neighbour baseline must be positive");
  }
  if (!(short_baseline_m >= 0 && short_baseline_m < neighbour_baseline_m)) {
    throw InputError(
        "the silhouette votes' short baseline must lie in [0, the neighbour baseline) m");
  }
  if (side_patch_px < 3 || side_guard_px < 0) {
    throw InputError("a silhouette side's patch needs at least 3 columns and no negative guard");
  }
  if (!(max_parallax_px >= 1)) throw InputError("the silhouette votes' parallax must reach 1 px");
  if (!(min_side_ncc >= -1 && min_side_ncc <= 1)) {
    throw InputError("a silhouette side's correlation must lie in [-1, 1]");
  }
  if (!(min_parallax_step_px >= 0 && flat_side_sd >= 0 && parallax_sd_px > 0)) {
    throw InputError("the silhouette sides' parallax step, flatness and SD must not be negative");
  }
  if (!(min_vote_span_m >= 0)) throw InputError("a silhouette's vote span must not be negative");
  if (min_votes_each_side < 0) {
    throw InputError("a silhouette vote candidate's votes on each side must not be negative");
  }
  if (min_votes < 1) throw InputError("a silhouette vote candidate needs at least one vote");
  if (min_cell_votes < 1 || min_cell_votes > min_votes) {
    throw InputError("a silhouette vote grid's cell needs between one vote and min_votes");
  }
  if (!(agree_radius_share >= 0 && agree_radius_m >= 0 && agree_min_two_sided_views >= 0 &&
        agree_min_views_each_side >= 0)) {
    throw InputError("the silhouette votes' agreement with a fit must not be negative");
  }
  if (!(min_separation_m >= 0)) {
    throw InputError("the silhouette vote candidates' separation must not be negative");
  }
}

bool FitAgreesWithVotes(const SilhouetteVoteOptions& o, const Eigen::Vector2d& vote_centre,
                        double vote_radius_m, const Eigen::Vector2d& centre, double radius_m,
                        int two_sided_views, int each_side_views) {
  const bool sides_seen =
      two_sided_views >= o.agree_min_two_sided_views ||
      (o.agree_min_views_each_side > 0 && each_side_views >= o.agree_min_views_each_side);
  return o.agree_min_two_sided_views > 0 && sides_seen &&
         std::abs(radius_m - vote_radius_m) <=
             o.agree_radius_share * vote_radius_m + o.agree_radius_m &&
         (centre - vote_centre).norm() <= std::max(vote_radius_m, o.cell_m);
}

namespace {

double Wrap(double a) { return std::remainder(a, 2 * M_PI); }

// One keyframe's strip of the picture, resampled so that each column is one world azimuth from
// the camera centre (a step of one pixel at the image centre) and each row one height at
// strip_range_m: a vertical line at any distance projects onto one column, and a point at
// infinity onto the same column in every view.
struct AzimuthStrip {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  int64_t first_index = 0;  // global azimuth index of column 0 (azimuth: index times step)
  cv::Mat_<float> luma;     // rows x columns; NaN outside the picture
  bool empty() const { return luma.empty(); }
};

AzimuthStrip MakeStrip(const SilhouetteVoteOptions& o, const PinholeCamera& cam,
                       const Rigid3d& world_from_cam, const cv::Mat& gray, double yaw,
                       double az_step) {
  AzimuthStrip s;
  const Eigen::Vector3d c = world_from_cam.translation;
  s.centre_xy = c.head<2>();
  const double half = 0.92 * std::atan(0.5 * cam.width / cam.fx);
  s.first_index = static_cast<int64_t>(std::ceil((yaw - half) / az_step));
  const int64_t last = static_cast<int64_t>(std::floor((yaw + half) / az_step));
  const int cols = static_cast<int>(last - s.first_index + 1);
  if (cols < 3) return s;
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  s.luma.create(o.strip_rows, cols);
  for (int col = 0; col < cols; ++col) {
    const double a = static_cast<double>(s.first_index + col) * az_step;
    const Eigen::Vector3d base = c + o.strip_range_m * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    for (int j = 0; j < o.strip_rows; ++j) {
      const double dz = (2.0 * j / (o.strip_rows - 1) - 1.0) * o.strip_half_height_m;
      const Eigen::Vector3d p = cam_from_world * (base + Eigen::Vector3d(0, 0, dz));
      float v = -1.f;
      if (p.z() > 0.1) {
        const Eigen::Vector2d px = cam.ImageFromCam(p);
        v = BilinearGray(gray, px.x(), px.y());
      }
      s.luma(j, col) = v < 0 ? std::numeric_limits<float>::quiet_NaN() : v;
    }
  }
  return s;
}

// Straight vertical edges of a strip: (column, subpixel offset) at local maxima of the mean
// step across two columns.
std::vector<double> StripEdges(const SilhouetteVoteOptions& o, const AzimuthStrip& s) {
  const int cols = s.luma.cols, rows = s.luma.rows;
  std::vector<double> step(cols, 0.0), score(cols, 0.0);
  for (int c = 1; c + 1 < cols; ++c) {
    double sum = 0, sum_abs = 0;
    bool valid = true;
    for (int j = 0; j < rows && valid; ++j) {
      const double d = s.luma(j, c + 1) - s.luma(j, c - 1);
      valid = std::isfinite(d);
      sum += d;
      sum_abs += std::abs(d);
    }
    if (!valid) continue;
    step[c] = std::abs(sum) / rows;
    if (step[c] >= o.min_edge_step && std::abs(sum) >= o.min_edge_straightness * sum_abs) {
      score[c] = step[c];
    }
  }
  std::vector<double> edges;
  for (int c = 2; c + 2 < cols; ++c) {
    if (score[c] == 0) continue;
    const bool peak = score[c] >= score[c - 1] && score[c] > score[c + 1] &&
                      score[c] >= score[c - 2] && score[c] > score[c + 2];
    if (!peak) continue;
    const double den = step[c - 1] - 2 * step[c] + step[c + 1];
    const double off = den < 0 ? std::clamp(0.5 * (step[c - 1] - step[c + 1]) / den, -0.5, 0.5) : 0;
    edges.push_back(c + off);
  }
  return edges;
}

struct SideMatch {
  double ncc = -1, parallax_px = 0, sd = 0;
};

// The patch of strip `a` at columns [c0, c0 + w) matched in strip `b` over parallaxes (columns
// of b minus a's at the same azimuth) in [-max, max]: the best zero-mean correlation, with a
// parabola's subpixel peak.
SideMatch MatchSide(const AzimuthStrip& a, const AzimuthStrip& b, int c0, int w, int max_px) {
  SideMatch m;
  const int rows = a.luma.rows;
  if (c0 < 0 || c0 + w > a.luma.cols) return m;
  double mean = 0;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < w; ++i) mean += a.luma(j, c0 + i);
  }
  const int n = rows * w;
  mean /= n;
  double var = 0;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < w; ++i) var += std::pow(a.luma(j, c0 + i) - mean, 2);
  }
  if (!std::isfinite(var)) return m;
  m.sd = std::sqrt(var / n);
  const int64_t offset = a.first_index - b.first_index;
  std::vector<double> ncc(2 * max_px + 1, -2.0);
  for (int p = -max_px; p <= max_px; ++p) {
    const int64_t b0 = c0 + offset + p;
    if (b0 < 0 || b0 + w > b.luma.cols) continue;
    double mb = 0;
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < w; ++i) mb += b.luma(j, static_cast<int>(b0) + i);
    }
    mb /= n;
    double cov = 0, vb = 0;
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < w; ++i) {
        const double db = b.luma(j, static_cast<int>(b0) + i) - mb;
        cov += (a.luma(j, c0 + i) - mean) * db;
        vb += db * db;
      }
    }
    if (!(vb > 0 && var > 0)) continue;
    ncc[p + max_px] = cov / std::sqrt(var * vb);
  }
  const auto best = std::ranges::max_element(ncc);
  if (*best < -1.5) return m;
  const int i = static_cast<int>(best - ncc.begin());
  m.ncc = *best;
  double off = 0;
  if (i > 0 && i + 1 < static_cast<int>(ncc.size()) && ncc[i - 1] > -1.5 && ncc[i + 1] > -1.5) {
    const double den = ncc[i - 1] - 2 * ncc[i] + ncc[i + 1];
    if (den < 0) off = std::clamp(0.5 * (ncc[i - 1] - ncc[i + 1]) / den, -0.5, 0.5);
  }
  m.parallax_px = i - max_px + off;
  return m;
}

// Distance along the ray from `o1` at azimuth a1 to where the ray from `o2` at azimuth a2 meets
// it; infinity where they do not meet in front of both.
double Triangulate(const Eigen::Vector2d& o1, double a1, const Eigen::Vector2d& o2, double a2) {
  const Eigen::Vector2d u1(std::cos(a1), std::sin(a1)), u2(std::cos(a2), std::sin(a2));
  Eigen::Matrix2d m;
  m << u1, -u2;
  const double det = m.determinant();
  if (std::abs(det) < 1e-9) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d ts = m.inverse() * (o2 - o1);
  if (ts.x() <= 0 || ts.y() <= 0) return std::numeric_limits<double>::infinity();
  return ts.x();
}

// One neighbour's verdict on an edge at strip column `edge`: which side lies nearer (+1 higher
// azimuth, -1 lower) and that side's parallax, or nothing where it cannot tell.
struct SideVerdict {
  int nearer = 0;
  double parallax_px = 0;
};

std::optional<SideVerdict> JudgeSides(const SilhouetteVoteOptions& o, const AzimuthStrip& a,
                                      const AzimuthStrip& b, double edge, double az_step) {
  const int c = static_cast<int>(std::lround(edge));
  const int w = o.side_patch_px, g = o.side_guard_px;
  const int max_px = static_cast<int>(o.max_parallax_px);
  const SideMatch lo = MatchSide(a, b, c - g - w, w, max_px);
  const SideMatch hi = MatchSide(a, b, c + g + 1, w, max_px);
  // The sign of parallax a nearer point takes: that of a point strip_range_m out.
  const double a_edge = edge * az_step + static_cast<double>(a.first_index) * az_step;
  const Eigen::Vector2d p =
      a.centre_xy + o.strip_range_m * Eigen::Vector2d(std::cos(a_edge), std::sin(a_edge));
  const Eigen::Vector2d d = p - b.centre_xy;
  const double sign = Wrap(std::atan2(d.y(), d.x()) - a_edge) >= 0 ? 1.0 : -1.0;
  const bool lo_flat = lo.sd <= o.flat_side_sd, hi_flat = hi.sd <= o.flat_side_sd;
  const bool lo_ok = !lo_flat && lo.ncc >= o.min_side_ncc;
  const bool hi_ok = !hi_flat && hi.ncc >= o.min_side_ncc;
  if (lo_ok && hi_ok) {
    const double gap = sign * (hi.parallax_px - lo.parallax_px);
    if (std::abs(gap) < o.min_parallax_step_px) return std::nullopt;
    return gap > 0 ? SideVerdict{1, hi.parallax_px} : SideVerdict{-1, lo.parallax_px};
  }
  if (lo_ok && hi_flat) return SideVerdict{-1, lo.parallax_px};
  if (hi_ok && lo_flat) return SideVerdict{1, hi.parallax_px};
  return std::nullopt;
}

// The keyframe nearest `k` along the turn (step -1 or +1) whose centre lies at least
// baseline_m from k's, or -1.
int NeighbourAlong(const std::vector<AzimuthStrip>& strips, int k, int step, double baseline_m) {
  const int n = static_cast<int>(strips.size());
  for (int j = k + step; j >= 0 && j < n && std::abs(j - k) <= 40; j += step) {
    if (strips[j].empty()) continue;
    if ((strips[j].centre_xy - strips[k].centre_xy).norm() >= baseline_m) return j;
  }
  return -1;
}

// The silhouette an edge of keyframe k's strip makes, where its neighbours tell its sides apart:
// each neighbour that tells them must tell the same, and the larger parallax places the surface
// best.
std::optional<SilhouetteRay> RayFromEdge(const SilhouetteVoteOptions& o,
                                         const std::vector<AzimuthStrip>& strips, int k,
                                         const std::array<int, 2>& neighbours, double edge,
                                         double az_step) {
  const AzimuthStrip& a = strips[k];
  std::optional<SideVerdict> verdict;
  int best_neighbour = -1;
  for (const int j : neighbours) {
    if (j < 0) continue;
    const std::optional<SideVerdict> v = JudgeSides(o, a, strips[j], edge, az_step);
    if (!v) continue;
    if (verdict && verdict->nearer != v->nearer) return std::nullopt;
    if (!verdict || std::abs(v->parallax_px) > std::abs(verdict->parallax_px)) {
      verdict = v;
      best_neighbour = j;
    }
  }
  if (!verdict) return std::nullopt;
  const double az = (static_cast<double>(a.first_index) + edge) * az_step;
  const AzimuthStrip& b = strips[best_neighbour];
  auto distance = [&](double parallax_px) {
    return Triangulate(a.centre_xy, az, b.centre_xy, az + parallax_px * az_step);
  };
  const double p = verdict->parallax_px;
  const double sign = p >= 0 ? 1.0 : -1.0;
  const double d = distance(p);
  if (!std::isfinite(d)) return std::nullopt;
  SilhouetteRay r;
  r.origin_xy = a.centre_xy;
  r.azimuth_rad = az;
  r.near_side = verdict->nearer;
  r.distance_m = d;
  r.min_distance_m = std::min(distance(p + sign * o.parallax_sd_px), d - o.min_vote_span_m);
  const double far = std::abs(p) > o.parallax_sd_px ? distance(p - sign * o.parallax_sd_px)
                                                    : std::numeric_limits<double>::infinity();
  r.max_distance_m = std::max(far, d + o.min_vote_span_m);
  return r;
}

// The unit normal of a silhouette's ray toward its nearer side.
Eigen::Vector2d NearNormal(const SilhouetteRay& ray) {
  return ray.near_side * Eigen::Vector2d(-std::sin(ray.azimuth_rad), std::cos(ray.azimuth_rad));
}

// Whether a silhouette votes for the stem `c`: its line moved by c's radius toward its nearer
// side passes within a cell and a half of c's centre, within the range its parallax allows.
bool Supports(const SilhouetteVoteOptions& o, const SilhouetteRay& ray, const VoteCandidate& c) {
  const Eigen::Vector2d q = c.centre_xy - ray.origin_xy;
  const double along = q.dot(Eigen::Vector2d(std::cos(ray.azimuth_rad), std::sin(ray.azimuth_rad)));
  return std::abs(NearNormal(ray).dot(q) - c.radius_m) <= 1.5 * o.cell_m &&
         along >= ray.min_distance_m - o.cell_m && along <= ray.max_distance_m + o.cell_m;
}

// The centre and radius the silhouettes voting for `c` give together: each is tangent to the
// stem, n . (centre - origin) = r with n the ray's normal toward its nearer side, solved by
// least squares over those whose moved line passes within a cell and a half of c's cell and
// whose range reaches it. Where their directions span too little to separate the radius from
// the distance, the radius stays and the centre alone is solved; where even that fails, or the
// solution moves farther than `max_move_m`, `c` stays as it is. Returns whether it moved.
bool RefineCandidateOnce(const SilhouetteVoteOptions& o, const std::vector<SilhouetteRay>& rays,
                         double max_move_m, VoteCandidate* c) {
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  int n = 0;
  for (const SilhouetteRay& ray : rays) {
    if (!Supports(o, ray, *c)) continue;
    const Eigen::Vector2d normal = NearNormal(ray);
    // normal . centre - r = normal . origin
    const Eigen::Vector3d row(normal.x(), normal.y(), -1.0);
    ata += row * row.transpose();
    atb += row * normal.dot(ray.origin_xy);
    ++n;
  }
  if (n < 3) return false;
  const Eigen::Vector3d full = ata.ldlt().solve(atb);
  const bool full_ok = std::isfinite(full.z()) && full.z() >= 0.5 * o.min_radius_m &&
                       full.z() <= o.max_radius_m + o.radius_step_m &&
                       (full.head<2>() - c->centre_xy).norm() < max_move_m &&
                       ata.determinant() > 1e-6 * std::pow(n, 3);
  if (full_ok) {
    c->centre_xy = full.head<2>();
    c->radius_m = full.z();
    return true;
  }
  // The radius fixed: normal . centre = normal . origin + r.
  const Eigen::Matrix2d a2 = ata.topLeftCorner<2, 2>();
  const Eigen::Vector2d b2 = atb.head<2>() - ata.topRightCorner<2, 1>() * c->radius_m;
  if (a2.determinant() <= 1e-6 * n * n) return false;
  const Eigen::Vector2d centre = a2.ldlt().solve(b2);
  if (!((centre - c->centre_xy).norm() < max_move_m)) return false;
  c->centre_xy = centre;
  return true;
}

// A few rounds of RefineCandidateOnce, each asking the silhouettes that vote where the last one
// placed it (a stem's silhouettes from a short arc cross along a ridge in the line of sight, and
// the cell with the most votes may lie anywhere on it), moving at most min_separation_m in all.
void RefineCandidate(const SilhouetteVoteOptions& o, const std::vector<SilhouetteRay>& rays,
                     VoteCandidate* c) {
  const Eigen::Vector2d start = c->centre_xy;
  for (int round = 0; round < 4; ++round) {
    VoteCandidate next = *c;
    if (!RefineCandidateOnce(o, rays, o.min_separation_m, &next)) return;
    if ((next.centre_xy - start).norm() > o.min_separation_m) return;
    const bool settled = (next.centre_xy - c->centre_xy).norm() < 0.1 * o.cell_m;
    *c = next;
    if (settled) return;
  }
}

}  // namespace

std::vector<SilhouetteRay> FindSilhouetteRays(const SilhouetteVoteOptions& o,
                                              const PinholeCamera& camera,
                                              const std::vector<StampedPose>& keyframes,
                                              const std::vector<cv::Mat>& gray) {
  o.Check();
  const int n = static_cast<int>(std::min(keyframes.size(), gray.size()));
  const double az_step = 1.0 / camera.fx;
  // The cameras' yaw, unwrapped along the turn so that neighbours' strips share azimuth indices.
  std::vector<double> yaw(n, 0.0);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d f = keyframes[k].world_from_cam.rotation * Eigen::Vector3d::UnitZ();
    const double a = std::atan2(f.y(), f.x());
    yaw[k] = k == 0 ? a : yaw[k - 1] + Wrap(a - yaw[k - 1]);
  }
  std::vector<AzimuthStrip> strips(n);
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < n; ++k) {
    if (gray[k].empty()) continue;
    strips[k] = MakeStrip(o, camera, keyframes[k].world_from_cam, gray[k], yaw[k], az_step);
  }
  std::vector<std::vector<SilhouetteRay>> per_view(n);
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < n; ++k) {
    if (strips[k].empty()) continue;
    const AzimuthStrip& a = strips[k];
    const std::array<int, 2> neighbours = {NeighbourAlong(strips, k, -1, o.neighbour_baseline_m),
                                           NeighbourAlong(strips, k, 1, o.neighbour_baseline_m)};
    // The keyframes short_baseline_m along, asked where those at the baseline cannot tell.
    std::array<int, 2> close_neighbours = {-1, -1};
    for (int side = 0; side < 2 && o.short_baseline_m > 0; ++side) {
      const int j = NeighbourAlong(strips, k, 2 * side - 1, o.short_baseline_m);
      if (j != neighbours[side]) close_neighbours[side] = j;
    }
    const bool any_close = close_neighbours[0] >= 0 || close_neighbours[1] >= 0;
    for (const double edge : StripEdges(o, a)) {
      std::optional<SilhouetteRay> ray = RayFromEdge(o, strips, k, neighbours, edge, az_step);
      if (!ray && any_close) ray = RayFromEdge(o, strips, k, close_neighbours, edge, az_step);
      if (ray) per_view[k].push_back(*ray);
    }
  }
  std::vector<SilhouetteRay> rays;
  for (auto& v : per_view) rays.insert(rays.end(), v.begin(), v.end());
  return rays;
}

namespace {

// The votes for stem centres: a grid of the plot plane for each radius voted for.
class VoteGrid {
 public:
  VoteGrid(const SilhouetteVoteOptions& o, double search_radius_m)
      : o_(o),
        extent_(search_radius_m + o.max_radius_m),
        cells_(static_cast<int>(std::ceil(2 * extent_ / o.cell_m))),
        radii_(static_cast<int>(std::floor((o.max_radius_m - o.min_radius_m) / o.radius_step_m)) +
               1),
        votes_(static_cast<size_t>(radii_) * cells_ * cells_, 0) {}

  // The ray's line moved by each radius toward its nearer side, over the distances its parallax
  // allows: one vote in each cell it crosses (one cell per step along its major axis).
  void Add(const SilhouetteRay& ray) {
    const Eigen::Vector2d u(std::cos(ray.azimuth_rad), std::sin(ray.azimuth_rad));
    const Eigen::Vector2d side = NearNormal(ray);
    const double t0 = std::max(ray.min_distance_m, 0.0);
    const double t1 = std::min(ray.max_distance_m, 2 * extent_);
    if (!(t1 > t0)) return;
    const double dt = o_.cell_m / std::max(std::abs(u.x()), std::abs(u.y()));
    const int steps = static_cast<int>(std::ceil((t1 - t0) / dt)) + 1;
    for (int ri = 0; ri < radii_; ++ri) {
      const Eigen::Vector2d start = ray.origin_xy + Radius(ri) * side;
      for (int i = 0; i < steps; ++i) {
        const Eigen::Vector2d q = start + (t0 + i * dt) * u;
        const int ix = static_cast<int>(std::floor((q.x() + extent_) / o_.cell_m));
        const int iy = static_cast<int>(std::floor((q.y() + extent_) / o_.cell_m));
        if (ix < 0 || iy < 0 || ix >= cells_ || iy >= cells_) continue;
        uint16_t& v = votes_[(static_cast<size_t>(ri) * cells_ + iy) * cells_ + ix];
        if (v < UINT16_MAX) ++v;
      }
    }
  }

  // Cells with at least min_cell_votes between min_range_m and search_radius_m of the plot centre,
  // most votes first (ties in the grid's order), at most max_peaks.
  std::vector<VoteCandidate> Peaks(double search_radius_m, size_t max_peaks) const {
    std::vector<std::pair<int, size_t>> cells;  // votes, index
    for (size_t i = 0; i < votes_.size(); ++i) {
      if (votes_[i] < o_.min_cell_votes) continue;
      const double range = Centre(i).norm();
      if (range >= o_.min_range_m && range <= search_radius_m) cells.emplace_back(votes_[i], i);
    }
    std::ranges::sort(cells, [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    std::vector<VoteCandidate> peaks;
    for (const auto& [votes, index] : cells) {
      VoteCandidate c{Centre(index), Radius(static_cast<int>(index / Layer())), votes};
      if (FarFromAll(peaks, c, o_.min_separation_m)) peaks.push_back(c);
      if (peaks.size() >= max_peaks) break;
    }
    return peaks;
  }

  // Whether c stands at least min_separation_m from every one of `others`.
  static bool FarFromAll(const std::vector<VoteCandidate>& others, const VoteCandidate& c,
                         double min_separation_m) {
    return std::ranges::none_of(others, [&](const VoteCandidate& k) {
      return (k.centre_xy - c.centre_xy).norm() < min_separation_m;
    });
  }

 private:
  size_t Layer() const { return static_cast<size_t>(cells_) * cells_; }
  double Radius(int ri) const { return o_.min_radius_m + ri * o_.radius_step_m; }
  Eigen::Vector2d Centre(size_t index) const {
    const size_t in_layer = index % Layer();
    const int ix = static_cast<int>(in_layer % cells_), iy = static_cast<int>(in_layer / cells_);
    return {-extent_ + (ix + 0.5) * o_.cell_m, -extent_ + (iy + 0.5) * o_.cell_m};
  }

  const SilhouetteVoteOptions& o_;
  double extent_;
  int cells_, radii_;
  std::vector<uint16_t> votes_;
};

}  // namespace

std::vector<VoteCandidate> VoteStemCentres(const SilhouetteVoteOptions& o,
                                           const std::vector<SilhouetteRay>& rays,
                                           double search_radius_m) {
  o.Check();
  VoteGrid grid(o, search_radius_m);
  for (const SilhouetteRay& ray : rays) grid.Add(ray);
  // Enough for every stem of a dense plot and the ridges its silhouettes leave along the line of
  // sight; the caller takes the listed stems away and keeps max_candidates.
  constexpr size_t kMaxPeaks = 1000;
  // Refined, each stands on the silhouettes that vote where it ends up, on both of its sides
  // (a stem's silhouettes from one side alone pile up along their common direction at any
  // radius); most votes first, one of any two that end up within min_separation_m.
  std::vector<VoteCandidate> refined;
  for (VoteCandidate c : grid.Peaks(search_radius_m, kMaxPeaks)) {
    RefineCandidate(o, rays, &c);
    if (c.centre_xy.norm() < o.min_range_m || c.centre_xy.norm() > search_radius_m) continue;
    std::array<int, 2> sides = {0, 0};
    for (const SilhouetteRay& ray : rays) {
      if (Supports(o, ray, c)) ++sides[ray.near_side > 0 ? 1 : 0];
    }
    c.votes = sides[0] + sides[1];
    if (std::min(sides[0], sides[1]) < o.min_votes_each_side || c.votes < o.min_votes) continue;
    refined.push_back(c);
  }
  std::ranges::stable_sort(
      refined, [](const VoteCandidate& a, const VoteCandidate& b) { return a.votes > b.votes; });
  std::vector<VoteCandidate> kept;
  for (const VoteCandidate& c : refined) {
    if (VoteGrid::FarFromAll(kept, c, o.min_separation_m)) kept.push_back(c);
  }
  return kept;
}

}  // namespace stemmap::stems
