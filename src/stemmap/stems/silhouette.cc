#include "stemmap/stems/silhouette.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace stemmap::stems {

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Silhouette as the strongest brightness step within `half_window` of x_pred whose outer side
// (dir: outward) looks like the background and whose inner side does not; `row` sums `rows`
// rows of the image, the lumas are per pixel. Sub-pixel by a parabola through the peak.
bool BrightnessEdge(const TangentOptions& o, const std::vector<double>& row, int rows,
                    double stem_luma, double bg_luma, int dir, double x_pred, double half_window,
                    double* x_edge) {
  const int width = static_cast<int>(row.size());
  if (std::abs(bg_luma - stem_luma) < o.min_brightness_contrast) return false;
  int best = -1;
  double best_g = 0;
  // Mean brightness 2-4 px to one side of i (towards: outward +1, inward -1).
  auto side_luma = [&](int i, int towards) {
    double sum = 0;
    int n = 0;
    for (int j = 2; j <= 4; ++j) {
      const int q = i + towards * dir * j;
      if (q >= 0 && q < width) sum += row[q], ++n;
    }
    return n ? sum / (n * rows) : -1e9;
  };
  for (int i = 1; i < width - 1; ++i) {
    if (std::abs(i - x_pred) > half_window) continue;
    const double out = std::abs(side_luma(i, 1) - bg_luma);
    const double in = std::abs(side_luma(i, -1) - bg_luma);
    if (!(out < in && out < 0.5 * o.min_brightness_contrast && in >= o.min_brightness_contrast))
      continue;
    const double g = std::abs(row[i + 1] - row[i - 1]);
    if (g > best_g) best_g = g, best = i;
  }
  if (best < 2 || best > width - 3 || best_g < 0.5 * o.min_brightness_contrast * rows) {
    return false;
  }
  const double sign = row[best + 1] >= row[best - 1] ? 1.0 : -1.0;
  const double gm = sign * (row[best] - row[best - 2]), gp = sign * (row[best + 2] - row[best]);
  const double den = gm - 2 * best_g + gp;
  const double off = den < 0 ? 0.5 * (gm - gp) / den : 0.0;
  *x_edge = best + std::clamp(off, -0.5, 0.5);
  return true;
}

// Where the texture profile, from the edge at `x` outward (dir), first falls below `level` for
// `run` columns on end, when that lies over a column beyond `x` (the texture goes on past it);
// the crossing interpolated.
bool TextureEndsBeyond(const std::vector<double>& texture, double x, int dir, double level, int run,
                       double* x_end) {
  const int n = static_cast<int>(texture.size());
  const int start = static_cast<int>(std::lround(x));
  if (start < 0 || start >= n) return false;
  std::vector<double> falling(n);  // rises where the texture falls, for FirstSustainedCrossing
  for (int i = 0; i < n; ++i) falling[i] = -texture[i];
  double crossing;
  if (!FirstSustainedCrossing(falling, start, dir, -level, run, &crossing)) return false;
  if (dir * (crossing - x) <= 1.5) return false;
  *x_end = crossing;
  return true;
}

// Whether the columns between `a` and `b` disagree with the neighbours, carried through the
// stem's surface, no more than `level` on average: bark of this stem, not of one behind it.
bool LinesUpLikeTheStem(const std::vector<double>& disagreement, double a, double b, double level) {
  const int n = static_cast<int>(disagreement.size());
  const int lo = std::max(0, static_cast<int>(std::lround(std::min(a, b))));
  const int hi = std::min(n - 1, static_cast<int>(std::lround(std::max(a, b))));
  if (hi < lo) return false;
  double sum = 0;
  for (int i = lo; i <= hi; ++i) sum += disagreement[i];
  return sum / (hi - lo + 1) <= level;
}

}  // namespace

std::pair<int, double> NearDepthSteps(const TangentOptions& o, double baseline_px, double dist_m) {
  // A point d out moves by b f / d against the neighbour (b f = baseline_px), so a depth step of
  // e moves it by b f e / d^2, and what lies 1.5 d out moves by b f / (3 d) against the stem.
  // Steps toward it leave it moving by at least twice background_parallax_px.
  if (o.near_depth_steps <= 0 || dist_m <= 0) return {0, 0.0};
  const double background_px = baseline_px / (3 * dist_m);
  const int steps =
      std::min(o.near_depth_steps,
               static_cast<int>(std::floor((background_px - 2 * o.background_parallax_px) /
                                           o.near_depth_step_px)));
  if (steps <= 0) return {0, 0.0};
  return {steps, o.near_depth_step_px * dist_m * dist_m / baseline_px};
}

// Silhouette columns of the stem in keyframe k at image row y0, from the disagreement between
// k and its neighbours warped through the stem's front plane.
Edges FindEdges(const TangentOptions& o, const TangentViews& v, int k, const Eigen::Vector2d& c0,
                double r0, double breast_z, double x_pred_left, double x_pred_right, double y0,
                const EdgeWindow& window) {
  Edges edges;
  if (window.hidden[0] && window.hidden[1]) return edges;
  const PinholeCamera& cam = *v.camera;
  const std::vector<StampedPose>& kfs = *v.keyframes;
  const cv::Mat& img = (*v.gray)[k];
  const Rigid3d& world_from_k = kfs[k].world_from_cam;
  const Eigen::Vector3d ck = world_from_k.translation;
  // Pixels are carried to the neighbours through the stem's own surface (the circle (c0, r0) at
  // every height), so bark lines up at any baseline; rays that miss it go through the plane of
  // the axis facing k, where they do not line up with what lies behind.
  Eigen::Vector3d n_w(ck.x() - c0.x(), ck.y() - c0.y(), 0.0);
  n_w.normalize();
  const double plane_d = n_w.dot(Eigen::Vector3d(c0.x(), c0.y(), breast_z));
  auto depth_along = [&](const Eigen::Vector3d& ray) {
    const Eigen::Vector2d q = ck.head<2>() - c0, u = ray.head<2>();
    const double a = u.squaredNorm(), b = q.dot(u), cq = q.squaredNorm() - r0 * r0;
    const double disc = b * b - a * cq;
    if (a > 1e-12 && disc >= 0) {
      const double t = (-b - std::sqrt(disc)) / a;
      if (t > 0) return t;
    }
    const double denom = n_w.dot(ray);
    return std::abs(denom) < 1e-9 ? -1.0 : (plane_d - n_w.dot(ck)) / denom;
  };
  // Neighbours far enough for what lies at 1.5 times the stem's distance to move by
  // background_parallax_px against the stem.
  const double dist = (ck.head<2>() - c0).norm();
  const double baseline_m = 3.0 * o.background_parallax_px * dist / cam.fx;
  const double half_w = 0.5 * (x_pred_right - x_pred_left);
  const double margin = std::max(o.search_px, o.search_share * half_w);
  // The search stops at the picture's borders (the window ends there for a side whose edge lies
  // beyond them); fewer columns than this leave no profile on either side of an edge.
  constexpr int kMinColumns = 8;
  int x_begin = std::max(1, static_cast<int>(std::floor(x_pred_left - margin)));
  int x_end = std::min(img.cols - 2, static_cast<int>(std::ceil(x_pred_right + margin)));
  const int y_begin = static_cast<int>(std::lround(y0)) - o.rows_half;
  const int y_end = static_cast<int>(std::lround(y0)) + o.rows_half;
  if (x_end - x_begin < kMinColumns || y_begin < 1 || y_end > img.rows - 2) return edges;
  int width = x_end - x_begin + 1;
  std::vector<double> diff(width, 0.0);
  std::vector<int> count(width, 0);
  std::vector<int> neighbours;
  for (int side : {-1, 1}) {
    int j = k + side;
    while (j + side >= 0 && j + side < static_cast<int>(kfs.size()) &&
           std::abs(j - k) < o.max_neighbour_offset &&
           (kfs[j].world_from_cam.translation - ck).head<2>().norm() < baseline_m) {
      j += side;
    }
    if (j >= 0 && j < static_cast<int>(kfs.size()) && !(*v.gray)[j].empty())
      neighbours.push_back(j);
  }
  // Depth steps (NearDepthSteps) for the nearer neighbour: each column keeps the depth at which
  // both neighbours agree with it best. Both at once, as one point's depth: moved in depth, what
  // lies behind shifts opposite ways in the two, and seldom lines up in both.
  double apart_m = 1e9;
  for (int j : neighbours) {
    apart_m = std::min(apart_m, (kfs[j].world_from_cam.translation - ck).head<2>().norm());
  }
  const auto [steps, step_m] = neighbours.empty()
                                   ? std::pair<int, double>{0, 0.0}
                                   : NearDepthSteps(o, apart_m * cam.fx, std::max(0.1, dist - r0));
  // With depth steps, every other row: the steps cost their number of warps, and a near stem's
  // bands hold rows to spare.
  const int row_step = steps > 0 ? 2 : 1;
  // Where each pixel's ray meets the stem's surface (or the axis plane), shared by both
  // neighbours; NaN where the ray goes away from it. Rows from y_begin by row_step.
  std::vector<Eigen::Vector3d> on_stem;
  on_stem.reserve(static_cast<size_t>((y_end - y_begin) / row_step + 1) * width);
  // Rotations as matrices: a quaternion costs twice the multiplications per pixel.
  const Eigen::Matrix3d world_from_k_rotation = world_from_k.rotation.toRotationMatrix();
  for (int y = y_begin; y <= y_end; y += row_step) {
    for (int x = x_begin; x <= x_end; ++x) {
      const Eigen::Vector3d ray = world_from_k_rotation * cam.CamRayFromImage({x, y});
      const double t = depth_along(ray);
      on_stem.push_back(t <= 0 ? Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())
                               : Eigen::Vector3d(ck + t * ray));
    }
  }
  // Each pixel's surface point in each neighbour's camera, and the move of one depth step there
  // (along the ray from k): a step then costs an addition, not a rotation.
  struct Warp {
    const cv::Mat* img;
    std::vector<Eigen::Vector3d> at, per_step;  // `at` NaN where the ray misses; no steps: none
  };
  std::vector<Warp> warps;
  for (int j : neighbours) {
    const Rigid3d j_from_world = kfs[j].world_from_cam.Inverse();
    const Eigen::Matrix3d j_from_world_rotation = j_from_world.rotation.toRotationMatrix();
    Warp w{&(*v.gray)[j], {}, {}};
    w.at.reserve(on_stem.size());
    for (const Eigen::Vector3d& p_w : on_stem) {
      w.at.push_back(j_from_world_rotation * p_w + j_from_world.translation);
    }
    if (steps > 0) {
      w.per_step.reserve(on_stem.size());
      for (const Eigen::Vector3d& p_w : on_stem) {
        w.per_step.push_back(j_from_world_rotation * (step_m * (p_w - ck).normalized()));
      }
    }
    warps.push_back(std::move(w));
  }
  std::vector<double> d(width);
  std::vector<int> n(width);
  for (int step = -steps; step <= steps; ++step) {
    std::ranges::fill(d, 0.0);
    std::ranges::fill(n, 0);
    for (const Warp& w : warps) {
      size_t i = 0;
      for (int y = y_begin; y <= y_end; y += row_step) {
        const uchar* row_k = img.ptr<uchar>(y);
        for (int x = x_begin; x <= x_end; ++x, ++i) {
          if (std::isnan(w.at[i].x())) continue;
          const Eigen::Vector3d p_j = step == 0 ? w.at[i] : w.at[i] + step * w.per_step[i];
          if (p_j.z() <= 0.1) continue;
          const Eigen::Vector2d px = cam.ImageFromCam(p_j);
          const float vj = BilinearGray(*w.img, px.x(), px.y());
          if (vj < 0) continue;
          d[x - x_begin] += std::abs(row_k[x] - vj);
          ++n[x - x_begin];
        }
      }
    }
    for (int i = 0; i < width; ++i) {
      const bool better = n[i] > 0 && (count[i] == 0 || d[i] * count[i] < diff[i] * n[i]);
      if (step == -steps || better) diff[i] = d[i], count[i] = n[i];
    }
  }
  // Columns no neighbour shows (beyond their pictures, at this one's border) end the window; a
  // gap inside it leaves no profile to search.
  const int first =
      static_cast<int>(std::ranges::find_if(count, [](int n) { return n > 0; }) - count.begin());
  const int last =
      width - 1 -
      static_cast<int>(std::find_if(count.rbegin(), count.rend(), [](int n) { return n > 0; }) -
                       count.rbegin());
  if (last - first < kMinColumns) return edges;
  if (first > 0 || last < width - 1) {  // only at the picture's borders: no copy otherwise
    diff = std::vector<double>(diff.begin() + first, diff.begin() + last + 1);
    count = std::vector<int>(count.begin() + first, count.begin() + last + 1);
    x_begin += first;
    x_end = x_begin + static_cast<int>(count.size()) - 1;
    width = x_end - x_begin + 1;
  }
  for (int i = 0; i < width; ++i) {
    if (count[i] == 0) return edges;
    diff[i] /= count[i];
  }
  std::vector<double> smooth(width);
  for (int i = 0; i < width; ++i) {
    const int a = std::max(0, i - 1), b = std::min(width - 1, i + 1);
    smooth[i] = (diff[a] + diff[i] + diff[b]) / 3.0;
  }
  // Brightness across the rows, for sub-pixel refinement on the image edge itself.
  std::vector<double> row(width, 0.0);
  for (int y = y_begin; y <= y_end; ++y) {
    for (int x = x_begin; x <= x_end; ++x) row[x - x_begin] += img.at<uchar>(y, x);
  }
  // Texture per column, where the texture rule asks for it (plain_background_texture_ratio):
  // the mean change down the rows (grey levels). Bark has it; a plain sky or haze has none, and a
  // silhouette, a sunlit side's border or the shading across a stem, all vertical, add none.
  std::vector<double> texture;
  auto texture_profile = [&]() -> const std::vector<double>& {
    if (!texture.empty()) return texture;
    texture.assign(width, 0.0);
    for (int y = y_begin; y <= y_end; ++y) {
      for (int x = x_begin; x <= x_end; ++x) {
        texture[x - x_begin] += std::abs(img.at<uchar>(y + 1, x) - img.at<uchar>(y - 1, x));
      }
    }
    for (double& t : texture) t /= y_end - y_begin + 1;
    return texture;
  };
  auto refine = [&](double x0) {
    // Strongest brightness step within 1.5 px of the depth edge; parabola through its peak.
    const int i0 = static_cast<int>(std::lround(x0 - x_begin));
    int best = -1;
    double best_g = 0;
    for (int i = std::max(1, i0 - 2); i <= std::min(width - 2, i0 + 2); ++i) {
      const double g = std::abs(row[i + 1] - row[i - 1]);
      if (g > best_g && std::abs(i - (x0 - x_begin)) <= 1.5) {
        best_g = g;
        best = i;
      }
    }
    if (best <= 1 || best >= width - 2 || best_g < 4.0 * (2 * o.rows_half + 1)) return x0;
    const double gm = std::abs(row[best] - row[best - 2]), gp = std::abs(row[best + 2] - row[best]);
    const double den = gm - 2 * best_g + gp;
    const double off = den < 0 ? 0.5 * (gm - gp) / den : 0.0;
    return x_begin + best + std::clamp(off, -0.5, 0.5);
  };
  const double xl = x_pred_left - x_begin, xr = x_pred_right - x_begin;
  const int rows = 2 * o.rows_half + 1;
  // One side's silhouette (dir -1: left, +1: right). Levels inside the stem come from the middle
  // half of the part this side sees (all of it, unless a nearer stem covers some), levels
  // outside from what lies beyond the edge up to the next nearer stem.
  auto scan = [&](int dir, double* x_edge) {
    const int side = dir > 0;
    const double x_pred = dir < 0 ? xl : xr;
    const double inner = window.inner_end[side] - x_begin;
    const double outer = window.outer_end[side] - x_begin;
    const double lo = dir < 0 ? xl : std::max(xl, inner), hi = dir < 0 ? std::min(xr, inner) : xr;
    const double xm = 0.5 * (lo + hi);
    std::vector<double> inside, outside, row_inside, row_beyond;
    for (int i = 0; i < width; ++i) {
      if (std::abs(i - xm) < 0.25 * (hi - lo)) {
        inside.push_back(smooth[i]);
        row_inside.push_back(row[i]);
      }
      if (dir * (i - outer) >= 0) continue;  // the next nearer stem
      if (dir * (i - x_pred) > 3) {
        outside.push_back(smooth[i]);
        row_beyond.push_back(row[i]);
      }
    }
    if (outside.size() < 3 || inside.empty()) return false;
    const int run_px = std::clamp(static_cast<int>(0.05 * (xr - xl)), 3, 10);
    const double stem = Median(inside);
    const double bg = Median(outside);
    bool found = false;
    double x = 0;
    if (bg - stem < o.min_contrast) {
      // What lies behind disagrees too little (plain sky, a smooth far background): the
      // silhouette is the strongest brightness step near the predicted edge. Either sign: a
      // sunlit side can be brighter than the background while the stem's middle is darker.
      found = BrightnessEdge(o, row, rows, Median(row_inside) / rows, Median(row_beyond) / rows,
                             dir, x_pred, std::max(3.0, 0.2 * (xr - xl)), &x);
      // A sunlit side as bright as the background leaves its border with the shaded middle the
      // strongest step: where the bark's texture goes on beyond the step and lines up there as
      // the stem's middle does (clearly, itself), the silhouette is where the texture ends.
      if (found && o.plain_background_texture_ratio > 0) {
        // A few columns without texture end the stem: the gap before a stem behind it.
        constexpr int kTextureGapPx = 3;
        const std::vector<double>& column_texture = texture_profile();
        std::vector<double> tex_inside, tex_outside;
        for (int i = 0; i < width; ++i) {
          if (std::abs(i - xm) < 0.25 * (hi - lo)) tex_inside.push_back(column_texture[i]);
          if (dir * (i - outer) < 0 && dir * (i - x) > run_px)
            tex_outside.push_back(column_texture[i]);
        }
        const double tex_stem = Median(tex_inside), tex_bg = Median(tex_outside);
        double x_end;
        if (tex_outside.size() >= 3 && tex_stem >= o.min_bark_texture &&
            tex_bg < o.min_bark_texture && tex_stem >= o.plain_background_texture_ratio * tex_bg &&
            TextureEndsBeyond(column_texture, x, dir, 0.5 * (tex_stem + tex_bg), kTextureGapPx,
                              &x_end) &&
            stem <= o.min_contrast &&
            LinesUpLikeTheStem(smooth, x, x_end, stem + 0.5 * o.min_contrast)) {
          x = x_end;
        }
      }
      if (found) x += x_begin;
    } else {
      found = FirstSustainedCrossing(smooth, static_cast<int>(std::lround(xm)), dir,
                                     0.5 * (stem + bg), run_px, &x);
      if (found) {
        x += x_begin;
        if (o.refine_on_brightness) x = refine(x);
      }
    }
    // An edge at the next nearer stem is that stem's.
    if (!found || dir * (window.outer_end[side] - x) < o.search_px / 4) return false;
    *x_edge = x;
    return true;
  };
  if (!window.hidden[0]) edges.left = scan(-1, &edges.x_left);
  if (!window.hidden[1]) edges.right = scan(1, &edges.x_right);
  edges.y = y0;
  return edges;
}

bool FirstSustainedCrossing(const std::vector<double>& profile, int start, int dir, double tau,
                            int run, double* x) {
  const int n = static_cast<int>(profile.size());
  auto inside = [&](int i) { return i >= 0 && i < n; };
  auto sustained = [&](int i) {
    double sum = 0;
    int count = 0;
    for (int q = 1; q <= run && inside(i + q * dir); ++q) sum += profile[i + q * dir], ++count;
    return count > 0 && sum / count > tau;
  };
  if (!inside(start)) return false;
  int i = start;
  while (inside(i + dir) && (profile[i + dir] <= tau || !sustained(i))) i += dir;
  if (!inside(i + dir)) return false;
  // Crossing between i (below) and i + dir (above), linearly interpolated.
  const double a = profile[i], b = profile[i + dir];
  const double f = b > a ? (tau - a) / (b - a) : 0.5;
  *x = i + dir * f;
  return true;
}

bool FitEdgeLine(const std::vector<double>& y, const std::vector<double>& x, double y0,
                 int min_points, double* x_at_y0, double* scatter_px) {
  const int n = static_cast<int>(x.size());
  if (n < min_points) return false;
  std::vector<double> slopes;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (std::abs(y[j] - y[i]) > 0.5) slopes.push_back((x[j] - x[i]) / (y[j] - y[i]));
    }
  }
  double b = slopes.empty() ? 0.0 : Median(slopes);
  std::vector<double> offsets(n), dev(n);
  for (int i = 0; i < n; ++i) offsets[i] = x[i] - b * (y[i] - y0);
  double a = Median(offsets);
  for (int i = 0; i < n; ++i) dev[i] = std::abs(offsets[i] - a);
  const double tol = std::max(1.0, 3.0 * 1.4826 * Median(dev));
  double sw = 0, sy = 0, sx = 0, syy = 0, sxy = 0;
  for (int i = 0; i < n; ++i) {
    if (std::abs(x[i] - (a + b * (y[i] - y0))) > tol) continue;
    const double dy = y[i] - y0;
    sw += 1, sy += dy, sx += x[i], syy += dy * dy, sxy += dy * x[i];
  }
  if (sw < min_points) return false;
  const double den = sw * syy - sy * sy;
  if (den > 1e-9) b = (sw * sxy - sy * sx) / den;
  a = (sx - b * sy) / sw;
  // A silhouette leans a few degrees at most.
  if (std::abs(b) > 0.15) return false;
  *x_at_y0 = a;
  if (scatter_px) {
    for (int i = 0; i < n; ++i) dev[i] = std::abs(x[i] - (a + b * (y[i] - y0)));
    *scatter_px = 1.4826 * Median(dev);
  }
  return true;
}

// The nearer stems (x, y, radius) in front of a stem at distance d along u from the camera centre
// cc: their silhouettes may cover its own or stand in its edge search.
std::vector<Eigen::Vector3d> FrontOccluders(const TangentOptions& o, const TangentViews& v,
                                            const Eigen::Vector2d& cc, const Eigen::Vector2d& u,
                                            double d, double r) {
  std::vector<Eigen::Vector3d> front;
  if (!v.occluders) return front;
  for (const Eigen::Vector3d& q : *v.occluders) {
    const Eigen::Vector2d to_q = q.head<2>() - cc;
    const double dq = to_q.norm();
    if (dq <= q.z() || dq + q.z() >= d - r) continue;  // not in front
    // The stem itself (its start, before the fit moved it), or one merged with it.
    if ((to_q - d * u).norm() < q.z() + r + o.occluder_min_gap_m) continue;
    // Beside the line of sight by more than a right angle: out of the picture.
    if (to_q.dot(u) <= 0) continue;
    front.push_back(q);
  }
  return front;
}

// Image columns (ascending) of the silhouettes of the vertical circle (centre, r) at height z
// seen from a camera at cc; false when a silhouette lies behind the camera.
bool BesideNearerStem(const std::vector<Eigen::Vector3d>& stems, const Eigen::Vector2d& c, double r,
                      double min_gap_m) {
  const double d = c.norm();
  if (d <= r) return false;
  const double half = std::asin(r / d), bearing = std::atan2(c.y(), c.x());
  for (const Eigen::Vector3d& q : stems) {
    const double dq = q.head<2>().norm();
    if (dq >= d - r - min_gap_m || dq <= q.z()) continue;
    const double apart = std::abs(std::remainder(std::atan2(q.y(), q.x()) - bearing, 2 * M_PI));
    if (apart - std::asin(q.z() / dq) - half < 2 * half) return true;
  }
  return false;
}

std::optional<Eigen::Vector3d> StemInView(const PinholeCamera& cam, const Rigid3d& cam_from_world,
                                          const Eigen::Vector2d& cc, const Eigen::Vector2d& c,
                                          double r, double breast_z) {
  if ((c - cc).norm() < r + 0.3) return std::nullopt;
  const Eigen::Vector3d p_cam = cam_from_world * Eigen::Vector3d(c.x(), c.y(), breast_z);
  if (p_cam.z() < 0.5) return std::nullopt;
  const double x = cam.ImageFromCam(p_cam).x();
  if (x < 0.08 * cam.width || x > 0.92 * cam.width) return std::nullopt;
  return p_cam;
}

bool SilhouetteColumns(const PinholeCamera& cam, const Rigid3d& cam_from_world,
                       const Eigen::Vector2d& cc, const Eigen::Vector2d& centre, double r, double z,
                       std::array<double, 2>* xs) {
  const Eigen::Vector2d to = centre - cc;
  const double d = to.norm();
  if (d <= r) return false;
  const double alpha = std::asin(r / d);
  for (int s = 0; s < 2; ++s) {
    const double a = (s == 0 ? 1 : -1) * (M_PI / 2 - alpha);
    const Eigen::Vector2d tp = centre + r * (Eigen::Rotation2Dd(a) * (-to / d));
    const Eigen::Vector3d p = cam_from_world * Eigen::Vector3d(tp.x(), tp.y(), z);
    if (p.z() < 0.1) return false;
    (*xs)[s] = cam.ImageFromCam(p).x();
  }
  if ((*xs)[0] > (*xs)[1]) std::swap((*xs)[0], (*xs)[1]);
  return true;
}

// The edge search a stem predicted at columns [xl, xr] has beside nearer stems at the given
// columns: a side whose edge one covers, or with less than `guard` px of the stem or of what lies
// behind it showing there, is hidden; otherwise the search stops at them.
EdgeWindow WindowBesideOccluders(const std::vector<std::array<double, 2>>& occluder_cols, double xl,
                                 double xr, double guard) {
  EdgeWindow w;
  w.inner_end = {xr, xl};
  for (const auto& [ol, orr] : occluder_cols) {
    if (ol < xl + guard && orr > xl - guard) {
      w.hidden[0] = true;
    } else if (orr <= xl - guard) {
      w.outer_end[0] = std::max(w.outer_end[0], orr);
    } else {
      w.inner_end[0] = std::min(w.inner_end[0], ol);
    }
    if (ol < xr + guard && orr > xr - guard) {
      w.hidden[1] = true;
    } else if (ol >= xr + guard) {
      w.outer_end[1] = std::min(w.outer_end[1], ol);
    } else {
      w.inner_end[1] = std::max(w.inner_end[1], orr);
    }
  }
  if (w.inner_end[0] - xl < 3 * guard || xl - w.outer_end[0] < 3 * guard) w.hidden[0] = true;
  if (xr - w.inner_end[1] < 3 * guard || w.outer_end[1] - xr < 3 * guard) w.hidden[1] = true;
  return w;
}

}  // namespace stemmap::stems
