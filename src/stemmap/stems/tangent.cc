#include "stemmap/stems/tangent.h"

#include <spdlog/spdlog.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "stemmap/core/error.h"
#include "stemmap/stems/silhouette.h"

namespace stemmap::stems {

void TangentOptions::Check() const {
  if (!(background_parallax_px > 0 && max_neighbour_offset >= 1)) {
    throw InputError("the silhouettes' neighbour views need a positive parallax and offset");
  }
  if (!(near_depth_steps >= 0 && near_depth_step_px > 0)) {
    throw InputError("the near stems' depth steps must not be negative, and each step positive");
  }
  if (!(rows_half >= 1 && band_half_height_m > 0 && band_half_height_m < 1 &&
        max_bands_each_side >= 1)) {
    throw InputError(
        "the silhouettes' bands need at least one row, and one band on each side, within 1 m of "
        "breast height");
  }
  if (!(search_px > 0 && search_share >= 0)) {
    throw InputError("the silhouettes' search must reach beyond the predicted edges");
  }
  if (!(min_contrast >= 0 && min_brightness_contrast >= 0)) {
    throw InputError("the silhouettes' contrasts must not be negative");
  }
  if (!(plain_background_texture_ratio == 0 || plain_background_texture_ratio >= 1) ||
      !(min_bark_texture >= 0)) {
    throw InputError(
        "the stem's texture over a plain background's must be at least 1 (or 0: off), and the "
        "bark's texture not negative");
  }
  if (!(huber_m > 0 && prior_share_of_distance > 0 && min_rays >= 3)) {
    throw InputError("the tangent fit needs a positive robust scale and prior, and 3 rays");
  }
  if (!(max_sideways_m >= 0 && max_move_m >= 0 && max_move_prior_sigmas >= 0 &&
        occluder_min_gap_m >= 0 && refits >= 0)) {
    throw InputError(
        "the tangent fit's sideways reach and move, occluder gap and refits must not be negative");
  }
  if (!std::ranges::all_of(wide_start_scales, [](double k) { return k > 1; })) {
    throw InputError("the wide starts' scales must exceed 1");
  }
  if (!std::ranges::all_of(narrow_start_scales, [](double k) { return k > 0 && k < 1; })) {
    throw InputError("the narrow starts' scales must lie in (0, 1)");
  }
  if (!std::ranges::all_of(sideways_start_shifts, [](double k) { return k > 0; })) {
    throw InputError("the sideways starts' shifts must be positive");
  }
  if (!(recheck_wider_scale >= 0 && recheck_min_gain >= 1 && recheck_rms_slack_px >= 0)) {
    throw InputError("the wider recheck needs a scale of at least 0 and a gain of at least 1");
  }
  if (!(narrow_max_rms_px > 0 && narrow_min_share >= 0 && narrow_min_share <= 1)) {
    throw InputError("the narrower fit's rms must be positive and its share within [0, 1]");
  }
  if (!(on_bark_max_rms_px >= 0)) {
    throw InputError("the rms of a fit the bark lines up on must not be negative");
  }
  if (!(rim_min_share >= 0 && rim_min_share <= 1)) {
    throw InputError("the share of a wider fit a fit inside it must reach must lie in [0, 1]");
  }
  if (!(tighter_rms_share >= 0 && tighter_rms_share <= 1)) {
    throw InputError("the rms share of a tighter fit must lie in [0, 1]");
  }
  if (!(pooled_min_extra_rays >= 0 && few_views_min_two_sided >= 0 && few_views_min_share >= 0 &&
        few_views_min_share <= 1)) {
    throw InputError(
        "the pooled and few-views fits' counts must not be negative, their share within [0, 1]");
  }
  if (!(min_views_each_side >= 0)) {
    throw InputError("the views each side needs must not be negative");
  }
  if (!(face_sigma_m >= 0 && face_start_growth > 1)) {
    throw InputError(
        "the sigma of a stem's face's range must not be negative, its starts' growth above 1");
  }
  if (!(settle_min_change_share >= 0)) {
    throw InputError("the change that leaves a fit unsettled must not be negative");
  }
  if (!(blur_sigma_px >= 0)) throw InputError("the silhouettes' blur must not be negative");
}

void PrepareTangentImages(const TangentOptions& o, std::vector<cv::Mat>* gray) {
  if (o.blur_sigma_px <= 0) return;
  for (cv::Mat& g : *gray) {
    if (!g.empty()) cv::GaussianBlur(g, g, cv::Size(0, 0), o.blur_sigma_px);
  }
}

namespace {

// Adds the rays' rows n . p - r = n . c (weight w_i) to the normal equations of (px, py, r).
void AddTangentRows(const std::vector<Eigen::Vector2d>& normals,
                    const std::vector<Eigen::Vector2d>& origins, const std::vector<double>& w,
                    Eigen::Matrix3d* ata, Eigen::Vector3d* atb) {
  for (size_t i = 0; i < normals.size(); ++i) {
    const Eigen::Vector3d a(normals[i].x(), normals[i].y(), -1.0);
    *ata += w[i] * a * a.transpose();
    *atb += w[i] * a * normals[i].dot(origins[i]);
  }
}

}  // namespace

bool SolveTangentCircle(const std::vector<Eigen::Vector2d>& normals,
                        const std::vector<Eigen::Vector2d>& origins, double huber_m,
                        Eigen::Vector2d* centre, double* radius, double* radius_sd, double* rms_m,
                        std::vector<double>* weights, const CentrePrior* prior, bool redescend) {
  const size_t n = normals.size();
  if (n < 3) return false;
  // Prior rows (p - c_prior) / sigma, in the rays' units: weight (ray_sigma / sigma)^2.
  Eigen::Matrix3d prior_ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d prior_atb = Eigen::Vector3d::Zero();
  if (prior) {
    const double w = std::pow(prior->ray_sigma_m / prior->sigma_m, 2);
    prior_ata.topLeftCorner<2, 2>() = w * Eigen::Matrix2d::Identity();
    prior_atb.head<2>() = w * prior->centre;
    if (prior->radius_sigma_m > 0) {
      const double wr = std::pow(prior->ray_sigma_m / prior->radius_sigma_m, 2);
      prior_ata(2, 2) = wr;
      prior_atb(2) = wr * prior->radius_m;
    }
    if (prior->face_sigma_m > 0) {
      // The face's row: bearing . c - r = face_range (linear in c near the bearing: the circle's
      // nearest point to the plot centre, |c| - r, to first order in the angle off it).
      const double wf = std::pow(prior->ray_sigma_m / prior->face_sigma_m, 2);
      const Eigen::Vector3d a(prior->face_bearing.x(), prior->face_bearing.y(), -1.0);
      prior_ata += wf * a * a.transpose();
      prior_atb += wf * prior->face_range_m * a;
    }
  }
  std::vector<double> w(n, 1.0);
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ata;
  // Huber first, from the plain least squares, to settle near the bulk of the rays; then Cauchy
  // (scale twice Huber's), whose weights fall to nothing for rays far off: an edge caught on a
  // neighbour, a shrub or a nearer stem's side keeps pulling a Huber fit by its full scale.
  const int kHuberIterations = 10, kIterations = redescend ? 20 : 10;
  const double cauchy_m = 2.0 * huber_m;
  for (int it = 0; it < kIterations; ++it) {
    ata = prior_ata;
    Eigen::Vector3d atb = prior_atb;
    AddTangentRows(normals, origins, w, &ata, &atb);
    if (std::abs(ata.determinant()) < 1e-12) return false;
    x = ata.ldlt().solve(atb);
    for (size_t i = 0; i < n; ++i) {
      const double e = std::abs(normals[i].dot(x.head<2>() - origins[i]) - x.z());
      w[i] = it + 1 < kHuberIterations ? (e <= huber_m ? 1.0 : huber_m / e)
                                       : 1.0 / (1.0 + (e / cauchy_m) * (e / cauchy_m));
    }
  }
  double sq = 0, wsum = 0;
  for (size_t i = 0; i < n; ++i) {
    const double e = normals[i].dot(x.head<2>() - origins[i]) - x.z();
    sq += w[i] * e * e;
    wsum += w[i];
  }
  const double sigma2 = sq / std::max(1.0, wsum - 3.0);
  *centre = x.head<2>();
  *radius = x.z();
  *radius_sd = std::sqrt(sigma2 * ata.inverse()(2, 2));
  *rms_m = std::sqrt(sq / wsum);
  if (weights) *weights = w;
  return std::isfinite(*radius) && *radius > 0;
}

namespace {

// What one keyframe's view gives a stem (centre c, radius r): a ray tangent to each silhouette
// side it found at breast height.
struct ViewRays {
  bool tried = false;
  int hidden_sides = 0;
  std::array<bool, 2> found = {false, false};
  std::array<Eigen::Vector2d, 2> normal;     // of each side's tangent ray, toward the stem
  std::array<double, 2> x = {0, 0};          // the silhouette's column at breast height
  std::array<double, 2> scatter_m = {0, 0};  // its bands' scatter about its line, at the stem
  double y = 0;                              // breast height's row
  Eigen::Vector2d origin;                    // the camera centre
  double heading = 0;                        // from the stem toward the camera
  int used() const { return found[0] + found[1]; }
};

ViewRays MeasureView(const TangentOptions& o, const TangentViews& v, const Eigen::Vector2d& c,
                     double r, double breast_z, size_t k) {
  ViewRays out;
  const PinholeCamera& cam = *v.camera;
  if ((*v.gray)[k].empty()) return out;
  const Rigid3d& world_from_cam = (*v.keyframes)[k].world_from_cam;
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  const Eigen::Vector2d cc = world_from_cam.translation.head<2>();
  const Eigen::Vector2d to_stem = c - cc;
  const double d = to_stem.norm();
  const std::optional<Eigen::Vector3d> in_view =
      StemInView(cam, cam_from_world, cc, c, r, breast_z);
  if (!in_view) return out;
  const Eigen::Vector3d p_cam = *in_view;
  const Eigen::Vector2d p_img = cam.ImageFromCam(p_cam);
  const Eigen::Vector2d u = to_stem / d;
  // Bands of rows, apart by their own height, within band_half_height_m of breast height; for a
  // near stem, seen large, at most max_bands_each_side on each side, spread over that height.
  const double px_per_m = cam.fx / p_cam.z();
  double band_step_m = (2 * o.rows_half + 1) / px_per_m;
  int bands = std::max(0, static_cast<int>(o.band_half_height_m / band_step_m));
  if (bands > o.max_bands_each_side) {
    bands = o.max_bands_each_side;
    band_step_m = o.band_half_height_m / bands;
  }
  std::vector<double> edge_y[2], edge_x[2];
  out.tried = true;
  const std::vector<Eigen::Vector3d> front = FrontOccluders(o, v, cc, u, d, r);
  std::array<bool, 2> hidden = {false, false};  // at breast height
  int in_frame = 0;                             // bands whose rows the picture holds
  for (int j = -bands; j <= bands; ++j) {
    const double z = breast_z + j * band_step_m;
    const double y = cam.ImageFromCam(cam_from_world * Eigen::Vector3d(c.x(), c.y(), z)).y();
    if (y - o.rows_half < 1 || y + o.rows_half > cam.height - 2) continue;
    ++in_frame;
    // Predicted silhouettes at this height, and the nearer stems' beside them.
    std::array<double, 2> xs;
    if (!SilhouetteColumns(cam, cam_from_world, cc, c, r, z, &xs)) continue;
    std::vector<std::array<double, 2>> occluder_cols;
    for (const Eigen::Vector3d& q : front) {
      std::array<double, 2> qs;
      if (SilhouetteColumns(cam, cam_from_world, cc, q.head<2>(), q.z(), z, &qs)) {
        occluder_cols.push_back(qs);
      }
    }
    const double guard_px = std::max(0.25 * o.search_px, 0.1 * (xs[1] - xs[0]));
    if (j == 0) hidden = WindowBesideOccluders(occluder_cols, xs[0], xs[1], guard_px).hidden;
    // The picture's borders end the search as a nearer stem does (but hide nothing of the stem):
    // a stem seen large shows one side in views where the other lies beyond the picture.
    occluder_cols.push_back({-1e9, 0.0});
    occluder_cols.push_back({cam.width - 1.0, 1e9});
    const EdgeWindow window = WindowBesideOccluders(occluder_cols, xs[0], xs[1], guard_px);
    const Edges e = FindEdges(o, v, static_cast<int>(k), c, r, z, xs[0], xs[1], y, window);
    if (e.left) edge_y[0].push_back(y), edge_x[0].push_back(e.x_left);
    if (e.right) edge_y[1].push_back(y), edge_x[1].push_back(e.x_right);
  }
  // Each side's line through more than half of the bands the picture holds, and at least three.
  if (in_frame < 3) return out;
  const int min_points = (in_frame + 1) / 2;
  out.origin = cc;
  out.y = p_img.y();
  out.heading = std::atan2(-u.y(), -u.x());
  for (int s = 0; s < 2; ++s) {
    if (hidden[s]) {
      ++out.hidden_sides;
      continue;
    }
    double x, scatter_px;
    if (!FitEdgeLine(edge_y[s], edge_x[s], p_img.y(), min_points, &x, &scatter_px)) continue;
    const Eigen::Vector3d ray = world_from_cam.rotation * cam.CamRayFromImage({x, p_img.y()});
    Eigen::Vector2d dir = ray.head<2>();
    if (dir.norm() < 1e-9) continue;
    dir.normalize();
    Eigen::Vector2d nrm(-dir.y(), dir.x());
    if (nrm.dot(c - cc) < 0) nrm = -nrm;
    out.found[s] = true;
    out.normal[s] = nrm;
    out.x[s] = x;
    out.scatter_m[s] = scatter_px * p_cam.z() / cam.fx;
  }
  return out;
}

}  // namespace

std::array<int, 2> SideViewsAt(const TangentOptions& o, const TangentViews& v,
                               const Eigen::Vector2d& c, double r, double breast_z) {
  const int n_views = static_cast<int>(v.keyframes->size());
  std::vector<ViewRays> per_view(n_views);
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < n_views; ++k) per_view[k] = MeasureView(o, v, c, r, breast_z, k);
  std::array<int, 2> views = {0, 0};
  for (const ViewRays& w : per_view) {
    for (int s = 0; s < 2; ++s) views[s] += w.found[s];
  }
  return views;
}

namespace {

// `face_range_m` > 0: the circle's face held at that range (CentrePrior::face_range_m).
TangentFit FitTangentRaysFrom(const TangentOptions& o, const TangentViews& v,
                              const Eigen::Vector2d& centre0, double radius0, double r_start,
                              double breast_z, double face_range_m = 0.0) {
  TangentFit fit;
  Eigen::Vector2d c = centre0;
  double r = r_start;
  const int n_views = static_cast<int>(v.keyframes->size());
  std::vector<ViewRays> per_view(n_views);
  for (int round = 0; round <= o.refits; ++round) {
    // Views are measured apart (in parallel) and gathered in keyframe order, so the fit does not
    // depend on the threads.
#pragma omp parallel for schedule(dynamic)
    for (int k = 0; k < n_views; ++k) per_view[k] = MeasureView(o, v, c, r, breast_z, k);
    std::vector<Eigen::Vector2d> normals, origins;
    std::vector<double> headings;
    std::vector<TangentFit::Ray> silhouettes;
    int views = 0, tried = 0, hidden_sides = 0, open_views = 0, two_sided = 0;
    std::array<int, 2> side_rays = {0, 0};
    for (int k = 0; k < n_views; ++k) {
      const ViewRays& w = per_view[k];
      tried += w.tried;
      hidden_sides += w.hidden_sides;
      open_views += w.tried && w.hidden_sides == 0;
      for (int s = 0; s < 2; ++s) {
        if (!w.found[s]) continue;
        // One line per silhouette for bench/silhouette_edges.py (image left = side 0).
        spdlog::trace(
            "tangent edge: start ({:.3f}, {:.3f}) r_start {:.4f} round {} keyframe {} t {:.4f} "
            "side {} x {:.2f} y {:.2f} scatter {:.1f} mm",
            centre0.x(), centre0.y(), r_start, round, k, (*v.keyframes)[k].t_s, s, w.x[s], w.y,
            1000 * w.scatter_m[s]);
        normals.push_back(w.normal[s]);
        origins.push_back(w.origin);
        silhouettes.push_back({k, s, w.normal[s], w.origin, w.heading, w.scatter_m[s]});
        ++side_rays[s];
      }
      if (w.used() == 2) ++two_sided;
      if (w.used() > 0) {
        ++views;
        const double h = w.heading;
        headings.push_back(
            headings.empty() ? h : headings[0] + std::remainder(h - headings[0], 2 * M_PI));
      }
    }
    spdlog::debug("tangent: stem ({:.2f}, {:.2f}) r {:.3f} round {}: {} views tried, {} rays",
                  c.x(), c.y(), r, round, tried, normals.size());
    if (static_cast<int>(normals.size()) < o.min_rays) return fit;
    Eigen::Vector2d c_new;
    double r_new, r_sd, rms;
    CentrePrior prior{centre0, o.PriorSigmaAt(centre0), o.huber_m};
    if (face_range_m > 0 && o.face_sigma_m > 0) {
      prior.face_bearing = centre0.normalized();
      prior.face_range_m = face_range_m;
      prior.face_sigma_m = o.face_sigma_m;
    }
    bool solved = SolveTangentCircle(normals, origins, o.huber_m, &c_new, &r_new, &r_sd, &rms,
                                     nullptr, &prior);
    auto implausible = [&] {
      return (c_new - centre0).norm() > o.MaxMoveFrom(centre0) || r_new > 3 * radius0 + 0.1;
    };
    if ((side_rays[0] == 0 || side_rays[1] == 0) && (!solved || implausible())) {
      // Rays from one side only leave the width free, and here they found none that fits: the
      // cloud's width holds it, the rays place it.
      prior.radius_m = radius0;
      prior.radius_sigma_m = 0.1 * o.huber_m;
      solved = SolveTangentCircle(normals, origins, o.huber_m, &c_new, &r_new, &r_sd, &rms, nullptr,
                                  &prior);
    }
    if (!solved) {
      spdlog::debug("tangent:   no circle fits ({} left, {} right rays; r {:.3f})", side_rays[0],
                    side_rays[1], r_new);
      return fit;
    }
    spdlog::debug("tangent:   solved ({:.2f}, {:.2f}) r {:.3f} rms {:.1f} mm", c_new.x(), c_new.y(),
                  r_new, 1000 * rms);
    if (implausible()) return fit;
    // The cloud misjudges depth, not bearing: a fit that moved sideways found another stem. A
    // wide start supposes the cloud saw part of the stem, whose centre may then lie its radius
    // to the side.
    const Eigen::Vector2d across = Eigen::Vector2d(-centre0.y(), centre0.x()).normalized();
    if (std::abs(across.dot(c_new - centre0)) > std::max(o.max_sideways_m, r_start)) return fit;
    // A refit that jumps away from an accepted one lost the silhouettes it had: keep that one.
    // One that found as many silhouettes or more around it converged onto the stem from a start
    // too wide or too narrow.
    if (fit.ok && std::abs(r_new - fit.radius_m) > 0.25 * fit.radius_m &&
        static_cast<int>(normals.size()) < fit.rays) {
      return fit;
    }
    fit.last_change_m = std::abs(r_new - r);
    c = c_new;
    r = r_new;
    fit.ok = true;
    fit.centre = c;
    fit.radius_m = r;
    fit.radius_sd_m = r_sd;
    fit.rms_m = rms;
    fit.rays = static_cast<int>(normals.size());
    fit.views = views;
    fit.hidden_sides = hidden_sides;
    fit.open_views = open_views;
    fit.tried_views = tried;
    fit.two_sided_views = two_sided;
    fit.silhouettes = std::move(silhouettes);
    if (!headings.empty()) {
      const auto [lo, hi] = std::minmax_element(headings.begin(), headings.end());
      fit.arc_deg = (*hi - *lo) * 180.0 / M_PI;
    }
  }
  return fit;
}

}  // namespace

double TangentFit::JaggedShare(double scatter_m, int side) const {
  int n = 0, jagged = 0;
  for (const Ray& ray : silhouettes) {
    if (side >= 0 && ray.side != side) continue;
    ++n;
    jagged += ray.edge_scatter_m > scatter_m;
  }
  return n > 0 ? static_cast<double>(jagged) / n : 0.0;
}
int TangentFit::SideViews(int side) const {
  std::vector<int> keyframes;
  for (const Ray& ray : silhouettes) {
    if (ray.side == side) keyframes.push_back(ray.keyframe);
  }
  std::ranges::sort(keyframes);
  return static_cast<int>(
      std::ranges::distance(keyframes.begin(), std::ranges::unique(keyframes).begin()));
}

TangentFit FitSidesOnFace(const TangentOptions& o, const TangentViews& v,
                          const Eigen::Vector2d& centre0, double radius0, double max_radius_m,
                          double face_range_m, double breast_z) {
  TangentFit best;
  if (o.face_sigma_m <= 0 || face_range_m <= 0 || centre0.norm() <= 0 || radius0 <= 0) {
    return best;
  }
  const Eigen::Vector2d bearing = centre0.normalized();
  auto rarer_side = [](const TangentFit& f) { return std::min(f.SideViews(0), f.SideViews(1)); };
  for (double r_start = radius0; r_start <= std::max(radius0, max_radius_m);
       r_start *= o.face_start_growth) {
    // Each start on the face: its centre a radius behind it.
    const TangentFit f = FitTangentRaysFrom(o, v, (face_range_m + r_start) * bearing, radius0,
                                            r_start, breast_z, face_range_m);
    if (!f.ok) continue;
    if (!best.ok || rarer_side(f) > rarer_side(best) ||
        (rarer_side(f) == rarer_side(best) && f.rays > best.rays)) {
      best = f;
    }
  }
  if (best.ok) {
    spdlog::debug(
        "tangent: on its face {:.2f} m out: ({:.2f}, {:.2f}) r {:.3f}, sides in {} and {} views, "
        "rms {:.1f} mm",
        face_range_m, best.centre.x(), best.centre.y(), best.radius_m, best.SideViews(0),
        best.SideViews(1), 1000 * best.rms_m);
  }
  return best;
}

bool SidesSeenApart(const TangentOptions& o, const TangentFit& fit, double px_m) {
  return o.min_views_each_side > 0 && fit.ok && fit.rms_m < o.narrow_max_rms_px * px_m &&
         fit.SideViews(0) >= o.min_views_each_side && fit.SideViews(1) >= o.min_views_each_side;
}

namespace {

// How keyframe k would see side `s` of the circle (c, r), where it tries the stem (MeasureView's
// gates): whether a nearer stem's outline or the picture's border covers it (within a quarter of
// the edge search's reach), whether the edge search would look for it (WindowBesideOccluders:
// not with too little beside it), and whether a nearer stem's outline lies between it and the
// other side.
struct SideSight {
  bool tried = false, covered = false, searched = false, past_nearer = false;
};

SideSight SideInView(const TangentOptions& o, const TangentViews& v, const Eigen::Vector2d& c,
                     double r, int s, double breast_z, size_t k) {
  const PinholeCamera& cam = *v.camera;
  const Rigid3d& world_from_cam = (*v.keyframes)[k].world_from_cam;
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  const Eigen::Vector2d cc = world_from_cam.translation.head<2>();
  const Eigen::Vector2d to_stem = c - cc;
  const double d = to_stem.norm();
  SideSight sight;
  if (!StemInView(cam, cam_from_world, cc, c, r, breast_z)) return sight;
  std::array<double, 2> xs;
  if (!SilhouetteColumns(cam, cam_from_world, cc, c, r, breast_z, &xs)) return sight;
  sight.tried = true;
  const double x_side = xs[s], x_other = xs[1 - s];
  const double edge_px = 0.25 * o.search_px;
  sight.covered = x_side < edge_px || x_side > cam.width - 1 - edge_px;
  std::vector<std::array<double, 2>> occluder_cols;
  for (const Eigen::Vector3d& q : FrontOccluders(o, v, cc, to_stem / d, d, r)) {
    std::array<double, 2> qs;
    if (!SilhouetteColumns(cam, cam_from_world, cc, q.head<2>(), q.z(), breast_z, &qs)) continue;
    sight.covered |= qs[0] < x_side + edge_px && qs[1] > x_side - edge_px;
    sight.past_nearer |= std::min(x_side, x_other) < qs[0] && qs[1] < std::max(x_side, x_other);
    occluder_cols.push_back(qs);
  }
  occluder_cols.push_back({-1e9, 0.0});
  occluder_cols.push_back({cam.width - 1.0, 1e9});
  const double guard_px = std::max(edge_px, 0.1 * (xs[1] - xs[0]));
  sight.searched = !WindowBesideOccluders(occluder_cols, xs[0], xs[1], guard_px).hidden[s];
  return sight;
}

}  // namespace

std::array<int, 2> SideViewsClearOfNearerStems(const TangentOptions& o, const TangentViews& v,
                                               const TangentFit& fit, double breast_z) {
  std::array<std::vector<int>, 2> keyframes;
  if (!fit.ok) return {0, 0};
  const PinholeCamera& cam = *v.camera;
  for (const TangentFit::Ray& ray : fit.silhouettes) {
    const Rigid3d cam_from_world = (*v.keyframes)[ray.keyframe].world_from_cam.Inverse();
    const Eigen::Vector2d to_stem = fit.centre - ray.origin;
    const double d = to_stem.norm();
    std::array<double, 2> xs;
    if (d <= fit.radius_m || !SilhouetteColumns(cam, cam_from_world, ray.origin, fit.centre,
                                                fit.radius_m, breast_z, &xs)) {
      continue;
    }
    // The silhouette's column: its tangent line, as far out as the stem.
    Eigen::Vector2d along(-ray.normal.y(), ray.normal.x());
    if (along.dot(to_stem) < 0) along = -along;
    const Eigen::Vector2d at = ray.origin + d * along;
    const Eigen::Vector3d p = cam_from_world * Eigen::Vector3d(at.x(), at.y(), breast_z);
    if (p.z() < 0.1) continue;
    const double x = cam.ImageFromCam(p).x();
    const double margin_px = 3 * std::max(0.25 * o.search_px, 0.1 * (xs[1] - xs[0]));
    bool clear = true;
    for (const Eigen::Vector3d& q :
         FrontOccluders(o, v, ray.origin, to_stem / d, d, fit.radius_m)) {
      std::array<double, 2> qs;
      if (SilhouetteColumns(cam, cam_from_world, ray.origin, q.head<2>(), q.z(), breast_z, &qs)) {
        clear &= x < qs[0] - margin_px || x > qs[1] + margin_px;
      }
    }
    if (clear) keyframes[ray.side].push_back(ray.keyframe);
  }
  std::array<int, 2> views;
  for (int s = 0; s < 2; ++s) {
    std::ranges::sort(keyframes[s]);
    const auto [first, last] = std::ranges::unique(keyframes[s]);
    keyframes[s].erase(first, last);
    views[s] = static_cast<int>(keyframes[s].size());
  }
  return views;
}

int ViewsShowingSide(const TangentOptions& o, const TangentViews& v, const Eigen::Vector2d& centre,
                     double radius_m, int side, double breast_z) {
  int n = 0;
  for (size_t k = 0; k < v.keyframes->size(); ++k) {
    const SideSight sight = SideInView(o, v, centre, radius_m, side, breast_z, k);
    n += sight.tried && sight.searched;
  }
  return n;
}

Eigen::Vector2d GrownHoldingFace(const Eigen::Vector2d& centre, double radius_m, int hidden_side,
                                 double grown_radius_m) {
  // Away from the plot centre and toward the hidden side by as much as the radius grows.
  const Eigen::Vector2d u = centre.normalized(), left(-u.y(), u.x());
  return centre + (grown_radius_m - radius_m) * (u + (hidden_side == 0 ? 1.0 : -1.0) * left);
}

double WidestRadiusWithSideHidden(const TangentOptions& o, const TangentViews& v,
                                  const Eigen::Vector2d& centre, double radius_m, int hidden_side,
                                  double breast_z, double max_radius_m) {
  const double d = centre.norm();
  if (d <= radius_m || radius_m <= 0 || !v.occluders) return radius_m;
  const int n_views = static_cast<int>(v.keyframes->size());
  double widest = radius_m;
  for (double r = radius_m * 1.02; r <= max_radius_m; r *= 1.02) {
    const Eigen::Vector2d c = GrownHoldingFace(centre, radius_m, hidden_side, r);
    // (Not the stem itself: an occluder its own circle already overlaps.)
    const bool into_stem = std::ranges::any_of(*v.occluders, [&](const Eigen::Vector3d& q) {
      return (q.head<2>() - c).norm() < q.z() + r &&
             (q.head<2>() - centre).norm() > q.z() + radius_m;
    });
    if (into_stem) break;
    int past_nearer = 0, hidden = 0;
    for (int k = 0; k < n_views; ++k) {
      const SideSight sight = SideInView(o, v, c, r, hidden_side, breast_z, k);
      past_nearer += sight.tried && !sight.covered && sight.past_nearer;
      hidden += sight.tried && sight.covered;
    }
    // Shown past a nearer stem in more than one view, or hidden in none: it would have been seen.
    if (past_nearer > 1 || hidden == 0) break;
    widest = r;
  }
  return widest;
}

// One circle for the silhouettes of every start (each once), robustly: it keeps the rays tangent
// to one circle, whichever start found them. Fills `pooled` from `chosen` with that circle and the
// silhouettes it keeps.
bool FitPooledSilhouettes(const TangentOptions& o, const std::vector<const TangentFit*>& fits,
                          const TangentFit& chosen, TangentFit* pooled) {
  std::vector<TangentFit::Ray> rays;
  for (const TangentFit* f : fits) {
    for (const TangentFit::Ray& r : f->silhouettes) {
      const bool seen = std::ranges::any_of(rays, [&](const TangentFit::Ray& q) {
        return q.keyframe == r.keyframe && q.side == r.side && (q.normal - r.normal).norm() < 1e-9;
      });
      if (!seen) rays.push_back(r);
    }
  }
  std::vector<Eigen::Vector2d> normals, origins;
  for (const TangentFit::Ray& r : rays) normals.push_back(r.normal), origins.push_back(r.origin);
  // Each fit's circle, reweighted (Cauchy) over the pooled rays from it: the pooled rays hold
  // several circles' worth of silhouettes, and one fitted to them all from their plain mean
  // settles between those. The circle tangent to the most rays wins.
  const double cauchy_m = 2.0 * o.huber_m;
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  int best_inliers = -1;
  for (const TangentFit* f : fits) {
    Eigen::Vector3d x(f->centre.x(), f->centre.y(), f->radius_m);
    for (int it = 0; it < 20; ++it) {
      std::vector<double> w(rays.size());
      for (size_t i = 0; i < rays.size(); ++i) {
        const double e = normals[i].dot(x.head<2>() - origins[i]) - x.z();
        w[i] = 1.0 / (1.0 + (e / cauchy_m) * (e / cauchy_m));
      }
      Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
      Eigen::Vector3d atb = Eigen::Vector3d::Zero();
      AddTangentRows(normals, origins, w, &ata, &atb);
      if (std::abs(ata.determinant()) < 1e-12) break;
      x = ata.ldlt().solve(atb);
    }
    if (!x.allFinite() || x.z() <= 0) continue;
    int inliers = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      inliers += std::abs(normals[i].dot(x.head<2>() - origins[i]) - x.z()) <= 2 * o.huber_m;
    }
    if (inliers > best_inliers) best = x, best_inliers = inliers;
  }
  if (best_inliers < o.min_rays) return false;
  // The circle and its spread from the rays tangent to it.
  std::vector<Eigen::Vector2d> in_normals, in_origins;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (std::abs(normals[i].dot(best.head<2>() - origins[i]) - best.z()) <= 2 * o.huber_m) {
      in_normals.push_back(normals[i]);
      in_origins.push_back(origins[i]);
    }
  }
  Eigen::Vector2d c;
  double r, r_sd, rms;
  const CentrePrior prior{best.head<2>(), o.PriorSigmaAt(best.head<2>()), o.huber_m};
  if (!SolveTangentCircle(in_normals, in_origins, o.huber_m, &c, &r, &r_sd, &rms, nullptr,
                          &prior)) {
    return false;
  }
  *pooled = chosen;
  pooled->centre = c;
  pooled->radius_m = r;
  pooled->radius_sd_m = r_sd;
  pooled->silhouettes.clear();
  std::map<int, int> sides_of_view;  // bit 0 left, bit 1 right
  std::vector<double> headings;
  double sq = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const double e = normals[i].dot(c - origins[i]) - r;
    if (std::abs(e) > 2 * o.huber_m) continue;
    sq += e * e;
    pooled->silhouettes.push_back(rays[i]);
    sides_of_view[rays[i].keyframe] |= 1 << rays[i].side;
    headings.push_back(headings.empty()
                           ? rays[i].heading
                           : headings[0] + std::remainder(rays[i].heading - headings[0], 2 * M_PI));
  }
  pooled->rays = static_cast<int>(pooled->silhouettes.size());
  if (pooled->rays < o.min_rays) return false;
  pooled->rms_m = std::sqrt(sq / pooled->rays);
  pooled->views = static_cast<int>(sides_of_view.size());
  pooled->two_sided_views = static_cast<int>(
      std::ranges::count_if(sides_of_view, [](const auto& kv) { return kv.second == 3; }));
  const auto [lo, hi] = std::minmax_element(headings.begin(), headings.end());
  pooled->arc_deg = (*hi - *lo) * 180.0 / M_PI;
  return true;
}

namespace {

// A few-views fit's bounds: no narrower than the cloud's sliver (a share of it), no wider than
// the widest start reaches, and within the sideways starts' reach across the line of sight.
bool WithinFewViewsBounds(const TangentOptions& o, const TangentFit& f,
                          const Eigen::Vector2d& centre0, double radius0) {
  const Eigen::Vector2d across = Eigen::Vector2d(-centre0.y(), centre0.x()).normalized();
  const double widest_shift =
      o.sideways_start_shifts.empty() ? 0.0 : *std::ranges::max_element(o.sideways_start_shifts);
  return f.radius_m > o.few_views_min_share * radius0 &&
         f.radius_m < o.WidestFitScale() * radius0 &&
         std::abs(across.dot(f.centre - centre0)) <
             std::max(o.max_sideways_m, (widest_shift + 1.0) * radius0);
}

}  // namespace

std::optional<TangentFit> FitSeenInFewViews(const TangentOptions& o,
                                            const std::vector<const TangentFit*>& ok_fits,
                                            const Eigen::Vector2d& centre0, double radius0,
                                            double px_m,
                                            const std::function<bool(const TangentFit&)>& accept) {
  auto stands = [&](const TangentFit& f) {
    return f.ok && f.two_sided_views >= o.few_views_min_two_sided &&
           f.rms_m < o.narrow_max_rms_px * px_m && WithinFewViewsBounds(o, f, centre0, radius0);
  };
  // Best first (most two-sided views, then most rays); only one the other evidence accepts
  // stands: the one with the most two-sided views may be a circle beside the stem that the bark
  // rejects, where another it accepts is the stem.
  std::vector<const TangentFit*> standing;
  for (const TangentFit* f : ok_fits) {
    if (stands(*f)) standing.push_back(f);
  }
  std::stable_sort(standing.begin(), standing.end(), [](const TangentFit* a, const TangentFit* b) {
    return a->two_sided_views > b->two_sided_views ||
           (a->two_sided_views == b->two_sided_views && a->rays > b->rays);
  });
  const TangentFit* best = nullptr;
  for (const TangentFit* f : standing) {
    if (!accept || accept(*f)) {
      best = f;
      break;
    }
  }
  if (!best) return std::nullopt;
  spdlog::debug("tangent: seen in few views ({:.2f}, {:.2f}) r {:.3f}: {} rays, {} two-sided",
                best->centre.x(), best->centre.y(), best->radius_m, best->rays,
                best->two_sided_views);
  return *best;
}

bool SettledFitReplaces(const TangentOptions& o, const TangentFit& few, const TangentFit& settled,
                        const Eigen::Vector2d& centre0, double radius0) {
  // A nearer stem hides sides at every radius, so one fewer view with both is no sign of a worse
  // circle; a looser or less supported one is.
  return settled.ok && settled.rays + 1 >= few.rays &&
         settled.two_sided_views + 1 >= few.two_sided_views && settled.rms_m <= few.rms_m &&
         WithinFewViewsBounds(o, settled, centre0, radius0);
}

namespace {

// Its start's rounds may end before the circle settles (a start too narrow or to the side finds a
// little more of the stem each round): more rounds from the chosen circle search where it
// predicts the silhouettes.
TangentFit SettleFewViewsFit(const TangentOptions& o, const TangentViews& v, const TangentFit& few,
                             const Eigen::Vector2d& centre0, double radius0, double breast_z,
                             const std::function<bool(const TangentFit&)>& accept) {
  if (!o.settle_few_views) return few;
  const TangentFit settled = FitTangentRaysFrom(o, v, few.centre, radius0, few.radius_m, breast_z);
  const bool replaces =
      SettledFitReplaces(o, few, settled, centre0, radius0) && (!accept || accept(settled));
  spdlog::debug("tangent: few-views fit settled{} ({:.2f}, {:.2f}) r {:.3f}: {} rays, {} two-sided",
                replaces ? "" : " (not kept)", settled.centre.x(), settled.centre.y(),
                settled.radius_m, settled.rays, settled.two_sided_views);
  return replaces ? settled : few;
}

}  // namespace

namespace {

// Whether a radius lies within the starts' reach of radius0: no narrower than the narrowest fit
// that can stand for the stem, nor as wide as the widest start.
bool WithinStartWidths(const TangentOptions& o, double radius_m, double radius0) {
  return radius_m > o.narrow_min_share * radius0 && radius_m < o.WidestFitScale() * radius0;
}

}  // namespace

bool WiderRecheckWins(const TangentOptions& o, const TangentFit& fit, const TangentFit& wider,
                      const Eigen::Vector2d& centre0, double radius0, double px_m) {
  const Eigen::Vector2d across = Eigen::Vector2d(-centre0.y(), centre0.x()).normalized();
  const bool as_tight =
      wider.rms_m <= fit.rms_m || (wider.two_sided_views >= fit.two_sided_views &&
                                   wider.rms_m <= fit.rms_m + o.recheck_rms_slack_px * px_m);
  return wider.ok && 2 * wider.two_sided_views >= wider.tried_views && as_tight &&
         wider.radius_m > o.recheck_min_gain * fit.radius_m &&
         wider.radius_m < o.WidestFitScale() * radius0 &&
         std::abs(across.dot(wider.centre - fit.centre)) < o.max_sideways_m;
}

namespace {

// The narrower starts (none just beside a nearer stem) and the starts moved sideways, each fit
// appended to `tried` and handed to `consider` with whether its start was moved sideways.
void TryNarrowAndSidewaysStarts(const TangentOptions& o, const TangentViews& v,
                                const Eigen::Vector2d& centre0, double radius0, double breast_z,
                                std::vector<TangentFit>* tried,
                                const std::function<void(const TangentFit&, bool)>& consider) {
  // Seen from the plot centre just beside a nearer stem, the cloud saw part of the stem at most:
  // its width is a lower bound, and a narrower start has nothing to correct (it settles on bark
  // inside the stem, under half its width).
  const bool beside_nearer =
      v.occluders && BesideNearerStem(*v.occluders, centre0, radius0, o.occluder_min_gap_m);
  for (double scale : beside_nearer ? std::vector<double>{} : o.narrow_start_scales) {
    tried->push_back(FitTangentRaysFrom(o, v, centre0, radius0, scale * radius0, breast_z));
    if (consider) consider(tried->back(), false);
  }
  const Eigen::Vector2d across = Eigen::Vector2d(-centre0.y(), centre0.x()).normalized();
  for (double shift : o.sideways_start_shifts) {
    for (double side : {-1.0, 1.0}) {
      const Eigen::Vector2d moved = centre0 + side * shift * radius0 * across;
      tried->push_back(FitTangentRaysFrom(o, v, moved, radius0, radius0, breast_z));
      if (consider) consider(tried->back(), true);
    }
  }
}

// The fit of the start FitTangentRays chooses; every start's fit is appended to `tried`.
// `others_tried`: set where the narrower and sideways starts were tried (not where the given
// radius's own fit was two-sided in most views).
TangentFit ChooseAmongStarts(const TangentOptions& o, const TangentViews& v,
                             const Eigen::Vector2d& centre0, double radius0, double breast_z,
                             const std::function<bool(const TangentFit&)>& accept,
                             std::vector<TangentFit>* tried_out, bool* others_tried) {
  std::vector<TangentFit>& tried = *tried_out;
  TangentFit fit = FitTangentRaysFrom(o, v, centre0, radius0, radius0, breast_z);
  tried.push_back(fit);
  const double px_m = centre0.norm() / v.camera->fx;
  // Most views two-sided: the start was right, unless a wider start settles on a wider circle
  // as cleanly. Neighbours are compared through the fitted circle, so one too narrow leaves the
  // bark beyond it misaligned, and its edges there hold it narrow; a circle too wide does not
  // make edges outside the stem.
  if (fit.ok && 2 * fit.two_sided_views >= fit.tried_views) {
    if (o.recheck_wider_scale <= 0) return fit;
    tried.push_back(
        FitTangentRaysFrom(o, v, centre0, radius0, o.recheck_wider_scale * radius0, breast_z));
    const TangentFit& wider = tried.back();
    const bool cleaner = WiderRecheckWins(o, fit, wider, centre0, radius0, px_m);
    if (cleaner) {
      spdlog::debug("tangent: wider start ({:.2f}, {:.2f}) r {:.3f} rms {:.1f} mm over r {:.3f}",
                    wider.centre.x(), wider.centre.y(), wider.radius_m, 1000 * wider.rms_m,
                    fit.radius_m);
    }
    return cleaner ? wider : fit;
  }
  // A narrower start must find both sides in several views, tangent to one circle to about a
  // pixel, and no narrower than a share of the cloud's width: inside a stem, bark and the border
  // of sun and shade give loose pairs of edges too.
  // Clearly more two-sided views than the fit so far (a few pairs also come from a sapling), both
  // sides on one circle to about a pixel.
  auto take_if_clearly_better = [&](const TangentFit& other) {
    const bool trusted = other.ok && other.two_sided_views >= 3 &&
                         other.rms_m < o.narrow_max_rms_px * px_m &&
                         other.radius_m > o.narrow_min_share * radius0;
    if (trusted && (!fit.ok || 2 * other.two_sided_views >= 3 * fit.two_sided_views)) fit = other;
  };
  // Away from where the cloud put it, only a stem seen whole in most views stands.
  TryNarrowAndSidewaysStarts(o, v, centre0, radius0, breast_z, &tried,
                             [&](const TangentFit& other, bool sideways) {
                               if (!sideways || 2 * other.two_sided_views >= other.tried_views) {
                                 take_if_clearly_better(other);
                               }
                             });
  *others_tried = true;
  const Eigen::Vector2d across = Eigen::Vector2d(-centre0.y(), centre0.x()).normalized();
  for (double scale : o.wide_start_scales) {
    tried.push_back(FitTangentRaysFrom(o, v, centre0, radius0, scale * radius0, breast_z));
    const TangentFit& other = tried.back();
    if (other.ok && (!fit.ok || other.two_sided_views > fit.two_sided_views ||
                     (other.two_sided_views == fit.two_sided_views && other.rays > fit.rays))) {
      fit = other;
    }
  }
  std::vector<const TangentFit*> ok_fits;
  for (const TangentFit& t : tried) {
    if (t.ok) ok_fits.push_back(&t);
  }
  if (o.few_views_min_two_sided > 0 && !fit.ok) {
    if (const std::optional<TangentFit> few =
            FitSeenInFewViews(o, ok_fits, centre0, radius0, px_m, accept)) {
      return SettleFewViewsFit(o, v, *few, centre0, radius0, breast_z, accept);
    }
  }
  if (!fit.ok || o.pooled_min_extra_rays < 0) return fit;
  TangentFit pooled;
  if (!FitPooledSilhouettes(o, ok_fits, fit, &pooled)) return fit;
  const bool in_place =
      std::abs(across.dot(pooled.centre - fit.centre)) < std::max(o.max_sideways_m, fit.radius_m) &&
      WithinStartWidths(o, pooled.radius_m, radius0);
  if (in_place && pooled.rays >= fit.rays + o.pooled_min_extra_rays &&
      pooled.two_sided_views >= fit.two_sided_views &&
      pooled.rms_m < std::max(fit.rms_m, o.narrow_max_rms_px * px_m)) {
    spdlog::debug("tangent: pooled silhouettes ({:.2f}, {:.2f}) r {:.3f}: {} rays, {} two-sided",
                  pooled.centre.x(), pooled.centre.y(), pooled.radius_m, pooled.rays,
                  pooled.two_sided_views);
    return pooled;
  }
  return fit;
}

}  // namespace

std::optional<TangentFit> FitTheBarkLinesUpOn(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&)>& bark) {
  std::vector<const TangentFit*> candidates;
  for (const TangentFit& f : tried) {
    const bool shaped = f.ok && f.two_sided_views >= 3 && 2 * f.two_sided_views >= f.tried_views &&
                        f.rms_m < o.on_bark_max_rms_px * px_m &&
                        WithinStartWidths(o, f.radius_m, radius0);
    // A circle around two things is wider than either: only a narrower fit can be the stem's
    // own (a wider one whose bark lines up may only fit the bark's curve better, as on an
    // elliptical stem, where the chosen circle's bark falls just short).
    if (shaped && f.radius_m < chosen.radius_m) candidates.push_back(&f);
  }
  std::ranges::stable_sort(candidates, [](const TangentFit* a, const TangentFit* b) {
    return a->two_sided_views > b->two_sided_views;
  });
  for (const TangentFit* f : candidates) {
    if (bark(*f) == BarkVerdict::kLinesUp) return *f;
  }
  return std::nullopt;
}

std::optional<TangentFit> TighterFitTheBarkAllows(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&)>& bark) {
  std::vector<const TangentFit*> candidates;
  for (const TangentFit& f : tried) {
    const bool stands = f.ok && f.rms_m < o.narrow_max_rms_px * px_m &&
                        (f.two_sided_views >= 3 || SidesSeenApart(o, f, px_m)) &&
                        WithinStartWidths(o, f.radius_m, radius0);
    if (stands && f.rms_m < o.tighter_rms_share * chosen.rms_m) candidates.push_back(&f);
  }
  std::ranges::stable_sort(candidates, [](const TangentFit* a, const TangentFit* b) {
    return a->two_sided_views > b->two_sided_views ||
           (a->two_sided_views == b->two_sided_views && a->rms_m < b->rms_m);
  });
  std::vector<BarkVerdict> verdicts;
  for (const TangentFit* f : candidates) {
    verdicts.push_back(bark(*f));
    if (verdicts.back() == BarkVerdict::kLinesUp) return *f;
  }
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (verdicts[i] == BarkVerdict::kSaysNothing) return *candidates[i];
  }
  return std::nullopt;
}

std::optional<TangentFit> FitWhoseRimIsBark(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&, double)>& rim) {
  const Eigen::Vector2d along = chosen.centre.normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  std::vector<const TangentFit*> around;
  for (const TangentFit& f : tried) {
    const double across_m = std::abs(across.dot(f.centre - chosen.centre));
    if (f.ok && f.radius_m >= o.recheck_min_gain * chosen.radius_m &&
        chosen.radius_m >= o.rim_min_share * f.radius_m &&
        f.radius_m < o.WidestFitScale() * radius0 && f.rms_m < o.on_bark_max_rms_px * px_m &&
        across_m <= f.radius_m - chosen.radius_m + px_m) {
      around.push_back(&f);
    }
  }
  std::ranges::stable_sort(
      around, [](const TangentFit* a, const TangentFit* b) { return a->rays > b->rays; });
  for (const TangentFit* f : around) {
    if (rim(*f, chosen.radius_m) == BarkVerdict::kLinesUp) return *f;
  }
  return std::nullopt;
}

bool SettledChosenFitReplaces(const TangentOptions& o, const TangentFit& chosen,
                              const TangentFit& settled, double radius0) {
  return settled.ok && settled.rays >= chosen.rays &&
         settled.two_sided_views >= chosen.two_sided_views && settled.rms_m <= chosen.rms_m &&
         WithinStartWidths(o, settled.radius_m, radius0);
}

namespace {

// A chosen fit whose last round still changed its radius is searched again from its own circle:
// the edges are searched where the new circle predicts them, so a start far outside a thin stem
// (a cloud smeared over what stands beside it) comes the rest of the way in. The new circle
// replaces it only when as tight, on as many silhouettes and both sides in as many views: a
// circle closing inside a stem on bark or a shadow's edge loses silhouettes where that edge
// fades, while the stem's own outline holds them all round the arc. Nor narrower than a fit
// that can stand for the stem: within a sapling's crown, the sapling's own stem.
TangentFit SettleChosenFit(const TangentOptions& o, const TangentViews& v, const TangentFit& fit,
                           double radius0, double breast_z) {
  if (o.settle_min_change_share <= 0 || !fit.ok ||
      fit.last_change_m <= o.settle_min_change_share * fit.radius_m) {
    return fit;
  }
  const TangentFit settled = FitTangentRaysFrom(o, v, fit.centre, radius0, fit.radius_m, breast_z);
  const bool replaces = SettledChosenFitReplaces(o, fit, settled, radius0);
  spdlog::debug(
      "tangent: settled{} ({:.2f}, {:.2f}) r {:.3f} over r {:.3f}: {} rays, {} two-sided, "
      "rms {:.1f} mm",
      replaces ? "" : " (not kept)", settled.centre.x(), settled.centre.y(), settled.radius_m,
      fit.radius_m, settled.rays, settled.two_sided_views, 1000 * settled.rms_m);
  return replaces ? settled : fit;
}

}  // namespace

TangentFit FitTangentRays(const TangentOptions& o, const TangentViews& v,
                          const Eigen::Vector2d& centre0, double radius0, double breast_z,
                          const std::function<bool(const TangentFit&)>& accept,
                          const std::function<BarkVerdict(const TangentFit&)>& bark,
                          const std::function<BarkVerdict(const TangentFit&, double)>& rim) {
  std::vector<TangentFit> tried;
  bool others_tried = false;
  TangentFit fit = SettleChosenFit(
      o, v, ChooseAmongStarts(o, v, centre0, radius0, breast_z, accept, &tried, &others_tried),
      radius0, breast_z);
  // A fit can close inside the stem: a circle too narrow misaligns the bark beyond it, whose
  // edges then hold it narrow, and shading across a round stem makes edges at a fixed share of
  // its apparent half-width in every view, tangent to a smaller concentric circle. Tangency
  // cannot tell them from the outline; the rim between the two circles can: inside the stem it
  // is bark, and lines up through the wider circle; beyond the stem's outline it is what lies
  // behind, at another depth. About two rims are compared per plot.
  if (fit.ok && rim && o.recheck_rim) {
    const double px_m = centre0.norm() / v.camera->fx;
    if (const std::optional<TangentFit> wider =
            FitWhoseRimIsBark(o, tried, fit, radius0, px_m, rim)) {
      spdlog::debug("tangent: ({:.2f}, {:.2f}) r {:.3f} replaces r {:.3f}: its rim is bark",
                    wider->centre.x(), wider->centre.y(), wider->radius_m, fit.radius_m);
      fit = *wider;
    }
  }
  // The starts' fits are ranked by their silhouettes alone, and a circle around two things
  // (a thin stem and the outline of a thicker one behind it, a stem and a gap) can show both
  // sides in more views than the stem's own. It does not warp one view's bark onto the next:
  // when the bark lines up nowhere on the chosen fit, a start's fit it lines up on replaces it.
  if (!fit.ok || !bark || bark(fit) != BarkVerdict::kLinesUpNowhere) return fit;
  const double px_m = centre0.norm() / v.camera->fx;
  std::optional<TangentFit> on_bark = FitTheBarkLinesUpOn(o, tried, fit, radius0, px_m, bark);
  // A circle around a thin stem and a thicker one behind it just beside its bearing shows both
  // sides in most views from the cloud's own start, where the cloud merged the two, and then no
  // narrower or sideways start was tried: try them now.
  if (!on_bark && !others_tried) {
    TryNarrowAndSidewaysStarts(o, v, centre0, radius0, breast_z, &tried, {});
    on_bark = FitTheBarkLinesUpOn(o, tried, fit, radius0, px_m, bark);
  }
  // A stem just beside a nearer one on its bearing: a start moved sideways that took the nearer
  // stem's edge for its own where it hides the stem settles on a looser circle between them, which
  // shows both sides in more views than the stem's own, and the bark lines up nowhere on it. The
  // stem's own fit, tighter, shows both sides in few views and its bark in few (a narrower fit
  // need not exist, so FitTheBarkLinesUpOn has none).
  if (!on_bark && o.tighter_rms_share > 0) {
    on_bark = TighterFitTheBarkAllows(o, tried, fit, radius0, px_m, bark);
  }
  if (!on_bark) return fit;
  spdlog::debug(
      "tangent: ({:.2f}, {:.2f}) r {:.3f} ({} two-sided, rms {:.1f} mm) replaces r {:.3f} (rms "
      "{:.1f} mm): the bark lines up nowhere on it",
      on_bark->centre.x(), on_bark->centre.y(), on_bark->radius_m, on_bark->two_sided_views,
      1000 * on_bark->rms_m, fit.radius_m, 1000 * fit.rms_m);
  return *on_bark;
}

}  // namespace stemmap::stems
