#include "stemmap/stems/ground.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "stemmap/core/error.h"

namespace stemmap::stems {

void GroundOptions::Check() const {
  if (!(cell_m >= 0.1 && cell_m <= 5)) throw InputError("the ground cell must lie in [0.1, 5] m");
  if (min_cell_points < 1) throw InputError("a ground cell needs at least one point");
  if (!(floor_bin_m > 0 && floor_min_points >= 1)) {
    throw InputError("a ground floor needs a layer thicker than 0 m and at least one point");
  }
  if (!(ground_layer_m > 0)) throw InputError("the ground layer must be thicker than 0 m");
  if (!std::is_sorted(windows_m.begin(), windows_m.end()) ||
      (!windows_m.empty() && !(windows_m.front() > 0))) {
    throw InputError("the ground filter's windows must be positive and growing");
  }
  if (!(min_rise_m >= 0 && max_slope >= 0)) {
    throw InputError("the ground filter's rise and slope must not be negative");
  }
  if (!(fill_radius_m >= 0)) throw InputError("the ground fill radius must not be negative");
  if (!(fill_one_sided_m > 0 && fill_slope_prior >= 0)) {
    throw InputError(
        "the ground fill's one-sided distance must be positive, the plot slope's weight not "
        "negative");
  }
  if (!(max_floor_at_view_bottom >= 0 && max_floor_at_view_bottom <= 1)) {
    throw InputError("the share of a cell's floor cut off by the frame must lie in [0, 1]");
  }
  if (min_rays_under_floor < 0 || !(max_pass_under_floor_m >= 0) || !(pass_end_clearance_m >= 0)) {
    throw InputError(
        "the rays under a ground cell's floor: count, depth and clearance must not be "
        "negative");
  }
  if (!(refine_below_m > 0 && refine_above_m > 0) || refine_iterations < 0) {
    throw InputError(
        "the ground's refinement needs a band reaching more than 0 m under and over the ground, "
        "and a non-negative number of iterations");
  }
}

namespace {

constexpr float kMissing = std::numeric_limits<float>::quiet_NaN();

// A point's height, and whether the frame's bottom edge cut the view at it.
struct CellPoint {
  float z;
  bool at_view_bottom;
  bool operator<(const CellPoint& other) const { return z < other.z; }
};

// The floor (lowest layer with enough points) of one cell's heights, sorted in place, and the
// median of its ground layer; false when no layer holds enough, or when the frame's edge cut off
// most views of it (the ground may lie lower).
bool CellGround(const GroundOptions& o, std::vector<CellPoint>* zs, float* floor, float* ground) {
  std::sort(zs->begin(), zs->end());
  const size_t need = static_cast<size_t>(o.floor_min_points);
  // The first point whose layer [z, z + floor_bin_m] holds `need` points.
  for (size_t i = 0; i + need <= zs->size(); ++i) {
    if ((*zs)[i + need - 1].z - (*zs)[i].z > o.floor_bin_m) continue;
    *floor = (*zs)[i].z;
    const auto bottom = zs->begin() + static_cast<std::ptrdiff_t>(i);
    const auto top = std::upper_bound(
        bottom, zs->end(), CellPoint{*floor + static_cast<float>(o.ground_layer_m), false});
    *ground = (bottom + (top - bottom) / 2)->z;
    // The floor itself (not the layer above it, where far views see bark past the shrubs that
    // hid its foot from them) decides whether the view ended there.
    const auto floor_top = std::upper_bound(
        bottom, zs->end(), CellPoint{*floor + static_cast<float>(o.floor_bin_m), false});
    const auto cut =
        std::count_if(bottom, floor_top, [](const CellPoint& p) { return p.at_view_bottom; });
    if (static_cast<double>(cut) <=
        o.max_floor_at_view_bottom * static_cast<double>(floor_top - bottom)) {
      return true;
    }
    *floor = *ground = kMissing;
    return false;
  }
  return false;
}

// Grey-level opening of `surface` (missing cells NaN) with a disc of `diameter` cells: the
// erosion ignores missing cells, the dilation too.
cv::Mat Opening(const cv::Mat& surface, int diameter) {
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(diameter, diameter));
  constexpr float kHigh = 1e6f;
  cv::Mat high = surface.clone();
  cv::patchNaNs(high, kHigh);
  cv::Mat eroded;
  cv::erode(high, eroded, disc, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(kHigh));
  eroded.setTo(-kHigh, eroded >= kHigh);
  cv::Mat opened;
  cv::dilate(eroded, opened, disc, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(-kHigh));
  opened.setTo(kMissing, opened <= -kHigh);
  return opened;
}

}  // namespace

GroundGrid::GroundGrid(const std::vector<dense::CloudPoint>& points, double radius_m,
                       const GroundOptions& o)
    : o_(o), origin_(-radius_m) {
  o.Check();
  n_ = static_cast<int>(std::ceil(2 * radius_m / o.cell_m));
  std::vector<std::vector<CellPoint>> zs(static_cast<size_t>(n_) * n_);
  for (const dense::CloudPoint& p : points) {
    const std::ptrdiff_t c = CellOf(p.world.x(), p.world.y());
    if (c >= 0) zs[static_cast<size_t>(c)].push_back({p.world.z(), p.at_view_bottom});
  }
  std::vector<float> floors(zs.size(), kMissing);
  z_.assign(zs.size(), kMissing);
  for (size_t c = 0; c < zs.size(); ++c) {
    if (static_cast<int>(zs[c].size()) < o.min_cell_points) continue;
    if (!CellGround(o, &zs[c], &floors[c], &z_[c])) continue;
    ++measured_;
  }
  DropFloorsSeenUnder(points, &floors);
  if (measured_ == 0) {  // nothing measured, or the camera saw under all of it
    n_ = 0;
    return;
  }
  const std::vector<char> is_ground = FilterGround(floors);
  FillFromGroundCells(is_ground);
  floor_z_ = z_;
  for (int k = 0; k < o.refine_iterations; ++k) {
    CentreOnPoints(points, is_ground);
    FillFromGroundCells(is_ground);
  }
}

std::ptrdiff_t GroundGrid::CellOf(double x, double y) const {
  const int i = static_cast<int>(std::floor((x - origin_) / o_.cell_m));
  const int j = static_cast<int>(std::floor((y - origin_) / o_.cell_m));
  if (i < 0 || j < 0 || i >= n_ || j >= n_) return -1;
  return static_cast<std::ptrdiff_t>(j) * n_ + i;
}

void GroundGrid::CentreOnPoints(const std::vector<dense::CloudPoint>& points,
                                const std::vector<char>& is_ground) {
  std::vector<std::vector<float>> residuals(z_.size());
  for (const dense::CloudPoint& p : points) {
    const std::ptrdiff_t c = CellOf(p.world.x(), p.world.y());
    if (c < 0 || !is_ground[static_cast<size_t>(c)]) continue;
    const double r = p.world.z() - Height(p.world.x(), p.world.y());
    if (r >= -o_.refine_below_m && r <= o_.refine_above_m) {
      residuals[static_cast<size_t>(c)].push_back(static_cast<float>(r));
    }
  }
  for (size_t c = 0; c < z_.size(); ++c) {
    std::vector<float>& r = residuals[c];
    if (static_cast<int>(r.size()) < o_.min_cell_points) continue;
    const auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
    std::nth_element(r.begin(), mid, r.end());
    z_[c] += *mid;
  }
}

void GroundGrid::DropFloorsSeenUnder(const std::vector<dense::CloudPoint>& points,
                                     std::vector<float>* floors) {
  if (o_.min_rays_under_floor <= 0) return;
  std::vector<int> under(floors->size(), 0);
  const double inv_cell = 1.0 / o_.cell_m;
  for (const dense::CloudPoint& p : points) {
    // The ray in cell units, up to pass_end_clearance_m short of its end (depth noise puts a
    // point past the surface it lies on).
    const Eigen::Vector2d a((p.origin.x() - origin_) * inv_cell,
                            (p.origin.y() - origin_) * inv_cell);
    const Eigen::Vector2d b((p.world.x() - origin_) * inv_cell, (p.world.y() - origin_) * inv_cell);
    const double length_m = (p.world - p.origin).norm();
    if (!(length_m > o_.pass_end_clearance_m)) continue;
    const double t_end = 1.0 - o_.pass_end_clearance_m / length_m;
    const Eigen::Vector2d d = b - a;
    int i = static_cast<int>(std::floor(a.x())), j = static_cast<int>(std::floor(a.y()));
    const int step_i = d.x() > 0 ? 1 : -1, step_j = d.y() > 0 ? 1 : -1;
    // Ray parameter at the next vertical and horizontal cell border, and between borders.
    const double dt_i = d.x() != 0 ? std::abs(1.0 / d.x()) : HUGE_VAL;
    const double dt_j = d.y() != 0 ? std::abs(1.0 / d.y()) : HUGE_VAL;
    double t_i = d.x() != 0 ? ((step_i > 0 ? i + 1 - a.x() : a.x() - i) * dt_i) : HUGE_VAL;
    double t_j = d.y() != 0 ? ((step_j > 0 ? j + 1 - a.y() : a.y() - j) * dt_j) : HUGE_VAL;
    double t_in = 0.0;
    const double z0 = p.origin.z(), dz = p.world.z() - p.origin.z();
    while (t_in < t_end) {
      const double t_out = std::min({t_i, t_j, t_end});
      if (i >= 0 && j >= 0 && i < n_ && j < n_) {
        const size_t c = static_cast<size_t>(j) * n_ + i;
        const double z_low = z0 + dz * (dz < 0 ? t_out : t_in);  // the ray's lowest in the cell
        if (z_low < (*floors)[c] - o_.max_pass_under_floor_m) ++under[c];
      }
      if (t_out >= t_end) break;
      if (t_i < t_j) {
        i += step_i;
        t_i += dt_i;
      } else {
        j += step_j;
        t_j += dt_j;
      }
      t_in = t_out;
    }
  }
  for (size_t c = 0; c < floors->size(); ++c) {
    if (under[c] >= o_.min_rays_under_floor && !std::isnan((*floors)[c])) {
      (*floors)[c] = kMissing;
      z_[c] = kMissing;
      --measured_;
    }
  }
}

std::vector<char> GroundGrid::FilterGround(const std::vector<float>& floors) const {
  cv::Mat surface = cv::Mat(n_, n_, CV_32F, const_cast<float*>(floors.data())).clone();
  std::vector<char> is_ground(floors.size(), 0);
  for (size_t c = 0; c < floors.size(); ++c) is_ground[c] = !std::isnan(floors[c]);
  for (double window_m : o_.windows_m) {
    const int diameter = std::max(1, static_cast<int>(std::lround(window_m / o_.cell_m)) | 1);
    const cv::Mat opened = Opening(surface, diameter);
    // Opening keeps a plane and lowers a mound: by at most the slope times the window's radius.
    const double rise_m = o_.min_rise_m + o_.max_slope * 0.5 * window_m;
    const float* surface_z = surface.ptr<float>();
    const float* opened_z = opened.ptr<float>();
    for (int c = 0; c < n_ * n_; ++c) {
      const float s = surface_z[c], t = opened_z[c];
      if (!std::isnan(s) && !std::isnan(t) && s - t > rise_m) is_ground[c] = 0;
    }
    surface = opened;
  }
  KeepTheLargestGroundPatch(floors, &is_ground);
  return is_ground;
}

void GroundGrid::KeepTheLargestGroundPatch(const std::vector<float>& floors,
                                           std::vector<char>* is_ground) const {
  // Ground cells join their 8 neighbours that are ground within a slope's step of them; islands
  // apart from the largest patch are what stands alone in a hole of the data (a sapling's crown
  // beside the tripod, where the camera sees no ground), which no opening can tell from ground.
  const double max_step_m = o_.min_rise_m + o_.max_slope * o_.cell_m * std::sqrt(2.0);
  std::vector<int> patch(floors.size(), -1), sizes;
  for (int start = 0; start < n_ * n_; ++start) {
    if (!(*is_ground)[start] || patch[start] >= 0) continue;
    const int id = static_cast<int>(sizes.size());
    sizes.push_back(0);
    std::vector<int> todo = {start};
    patch[start] = id;
    while (!todo.empty()) {
      const int c = todo.back();
      todo.pop_back();
      ++sizes[id];
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int i = c % n_ + di, j = c / n_ + dj;
          if (i < 0 || j < 0 || i >= n_ || j >= n_) continue;
          const int g = j * n_ + i;
          if (!(*is_ground)[g] || patch[g] >= 0 || std::abs(floors[g] - floors[c]) > max_step_m) {
            continue;
          }
          patch[g] = id;
          todo.push_back(g);
        }
      }
    }
  }
  if (sizes.empty()) return;
  const int largest =
      static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  for (int c = 0; c < n_ * n_; ++c) (*is_ground)[c] = (*is_ground)[c] && patch[c] == largest;
}

void GroundGrid::FillFromGroundCells(const std::vector<char>& is_ground) {
  auto centre = [&](int c) {
    return Eigen::Vector2d(origin_ + (c % n_ + 0.5) * o_.cell_m,
                           origin_ + (c / n_ + 0.5) * o_.cell_m);
  };
  // The plane through the ground cells, for places far from all of them, and the one through
  // those near the axis.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero(), axis_ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero(), axis_atb = Eigen::Vector3d::Zero();
  int axis_cells = 0;
  ground_ = 0;
  for (int c = 0; c < n_ * n_; ++c) {
    if (!is_ground[c]) continue;
    ++ground_;
    const Eigen::Vector2d xy = centre(c);
    const Eigen::Vector3d row(xy.x(), xy.y(), 1.0);
    ata += row * row.transpose();
    atb += row * z_[c];
    if (xy.norm() <= o_.axis_plane_radius_m) {
      axis_ata += row * row.transpose();
      axis_atb += row * z_[c];
      ++axis_cells;
    }
  }
  const Eigen::Vector3d plane =
      ground_ >= 3 ? Eigen::Vector3d(ata.ldlt().solve(atb)) : Eigen::Vector3d::Zero();
  axis_height_m_ = axis_cells >= 3 ? axis_ata.ldlt().solve(axis_atb).z()
                                   : std::numeric_limits<double>::quiet_NaN();
  const int reach = static_cast<int>(std::ceil(o_.fill_radius_m / o_.cell_m));
  std::vector<float> filled = z_;
  for (int c = 0; c < n_ * n_; ++c) {
    if (is_ground[c]) continue;
    const int ci = c % n_, cj = c / n_;
    const Eigen::Vector2d xy = centre(c);
    // The local plane in coordinates about this cell: its constant term is the height here.
    Eigen::Matrix3d local_ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d local_atb = Eigen::Vector3d::Zero();
    int near = 0;
    for (int j = std::max(0, cj - reach); j <= std::min(n_ - 1, cj + reach); ++j) {
      for (int i = std::max(0, ci - reach); i <= std::min(n_ - 1, ci + reach); ++i) {
        const int g = j * n_ + i;
        if (!is_ground[g]) continue;
        const Eigen::Vector2d d = o_.cell_m * Eigen::Vector2d(i - ci, j - cj);
        if (d.norm() > o_.fill_radius_m) continue;
        const double w = 1.0 / d.squaredNorm();
        const Eigen::Vector3d row(d.x(), d.y(), 1.0);
        local_ata += w * row * row.transpose();
        local_atb += w * row * z_[g];
        ++near;
      }
    }
    // Ground cells on one side only, or too few, tilt a local plane: the plot's plane instead.
    const bool spread = near >= 6 && local_ata.determinant() > 1e-9 * std::pow(local_ata(2, 2), 3);
    if (!spread) {
      filled[c] = static_cast<float>(plane.x() * xy.x() + plane.y() * xy.y() + plane.z());
      continue;
    }
    // Their weighted centre metres away on one side (under the tripod, where the camera sees no
    // ground): the slope of those few cells, tilted by their bumps, would tilt the height carried
    // in. There the local slope leans on the plot's, as much as fill_slope_prior cells around
    // would (with weights 1/d², each cell adds about one to the slope's terms, wherever it lies).
    const Eigen::Vector2d towards(local_ata(0, 2), local_ata(1, 2));
    if (towards.norm() > o_.fill_one_sided_m * local_ata(2, 2)) {
      Eigen::Matrix3d ata = local_ata;
      Eigen::Vector3d atb = local_atb;
      ata(0, 0) += o_.fill_slope_prior;
      ata(1, 1) += o_.fill_slope_prior;
      atb(0) += o_.fill_slope_prior * plane.x();
      atb(1) += o_.fill_slope_prior * plane.y();
      filled[c] = static_cast<float>(ata.ldlt().solve(atb).z());
      continue;
    }
    filled[c] = static_cast<float>(local_ata.ldlt().solve(local_atb).z());
  }
  z_ = std::move(filled);
}

GroundGrid::Slope GroundGrid::PlaneSlope(double radius_m) const {
  // z = a·x + b·y + c by the normal equations.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atz = Eigen::Vector3d::Zero();
  for (int j = 0; j < n_; ++j) {
    for (int i = 0; i < n_; ++i) {
      const Eigen::Vector3d row(origin_ + (i + 0.5) * o_.cell_m, origin_ + (j + 0.5) * o_.cell_m,
                                1.0);
      if (row.head<2>().norm() > radius_m) continue;
      const double z = z_[static_cast<size_t>(j) * n_ + i];
      if (!std::isfinite(z)) continue;
      ata += row * row.transpose();
      atz += row * z;
    }
  }
  if (ata(2, 2) < 3) return {};
  const Eigen::Vector3d abc = ata.ldlt().solve(atz);
  Slope s;
  s.slope_deg = std::atan(abc.head<2>().norm()) * 180.0 / M_PI;
  double az = std::atan2(-abc.y(), -abc.x()) * 180.0 / M_PI;
  s.downhill_azimuth_deg = az < 0 ? az + 360.0 : az;
  return s;
}

double GroundGrid::UphillHeight(double x, double y, double radius_m) const {
  double z = Height(x, y);
  constexpr int kBearings = 16;
  for (int k = 0; k < kBearings; ++k) {
    const double a = 2 * M_PI * k / kBearings;
    z = std::max(z, Height(x + radius_m * std::cos(a), y + radius_m * std::sin(a)));
  }
  return z;
}

double GroundGrid::Interpolate(const std::vector<float>& z, double x, double y) const {
  if (n_ == 0) return 0.0;
  const double fx = std::clamp((x - origin_) / o_.cell_m - 0.5, 0.0, n_ - 1.0);
  const double fy = std::clamp((y - origin_) / o_.cell_m - 0.5, 0.0, n_ - 1.0);
  const int i = std::min(static_cast<int>(fx), std::max(0, n_ - 2));
  const int j = std::min(static_cast<int>(fy), std::max(0, n_ - 2));
  const double u = fx - i, v = fy - j;
  auto at = [&](int a, int b) {
    return static_cast<double>(
        z[static_cast<size_t>(std::min(b, n_ - 1)) * n_ + std::min(a, n_ - 1)]);
  };
  return (1 - u) * (1 - v) * at(i, j) + u * (1 - v) * at(i + 1, j) + (1 - u) * v * at(i, j + 1) +
         u * v * at(i + 1, j + 1);
}

}  // namespace stemmap::stems
