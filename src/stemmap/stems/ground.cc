#include "stemmap/stems/ground.h"

#include <algorithm>
#include <cmath>

namespace stemmap::stems {

GroundGrid::GroundGrid(const std::vector<dense::CloudPoint>& points, double radius_m, double cell_m)
    : cell_(cell_m), origin_(-radius_m) {
  n_ = static_cast<int>(std::ceil(2 * radius_m / cell_m));
  std::vector<std::vector<float>> zs(static_cast<size_t>(n_) * n_);
  for (const dense::CloudPoint& p : points) {
    const int i = static_cast<int>((p.world.x() - origin_) / cell_);
    const int j = static_cast<int>((p.world.y() - origin_) / cell_);
    if (i < 0 || j < 0 || i >= n_ || j >= n_) continue;
    zs[static_cast<size_t>(j) * n_ + i].push_back(p.world.z());
  }
  const float kMissing = std::numeric_limits<float>::quiet_NaN();
  z_.assign(zs.size(), kMissing);
  for (size_t c = 0; c < zs.size(); ++c) {
    std::vector<float>& v = zs[c];
    if (v.size() < 8) continue;
    // A low percentile, not the minimum: stereo outliers fall below the ground too.
    const size_t q = v.size() / 20;
    std::nth_element(v.begin(), v.begin() + q, v.end());
    z_[c] = v[q];
    ++measured_;
  }
  // Cells well above a robust plane through all cells are trunks, shrubs or stems seen without the
  // ground below them (near the tripod the camera sees no ground): they and the empty cells take
  // the plane's height.
  FitPlaneAndDropRaisedCells();
  for (size_t c = 0; c < z_.size(); ++c) {
    if (std::isnan(z_[c])) {
      const double x = origin_ + (static_cast<int>(c % n_) + 0.5) * cell_;
      const double y = origin_ + (static_cast<int>(c / n_) + 0.5) * cell_;
      z_[c] = static_cast<float>(plane_.x() * x + plane_.y() * y + plane_.z());
    }
  }
  if (measured_ == 0) n_ = 0;
}

void GroundGrid::FitPlaneAndDropRaisedCells() {
  std::vector<Eigen::Vector3d> cells;
  for (size_t c = 0; c < z_.size(); ++c) {
    if (std::isnan(z_[c])) continue;
    cells.emplace_back(origin_ + (static_cast<int>(c % n_) + 0.5) * cell_,
                       origin_ + (static_cast<int>(c / n_) + 0.5) * cell_, z_[c]);
  }
  if (cells.size() < 10) return;
  // z = a x + b y + c, reweighted so that cells above it count little: the ground is the floor.
  std::vector<double> w(cells.size(), 1.0);
  for (int it = 0; it < 8; ++it) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < cells.size(); ++k) {
      const Eigen::Vector3d a(cells[k].x(), cells[k].y(), 1.0);
      ata += w[k] * a * a.transpose();
      atb += w[k] * a * cells[k].z();
    }
    plane_ = ata.ldlt().solve(atb);
    for (size_t k = 0; k < cells.size(); ++k) {
      const double e =
          cells[k].z() - (plane_.x() * cells[k].x() + plane_.y() * cells[k].y() + plane_.z());
      w[k] = e > 0.1 ? std::pow(0.1 / e, 2) : 1.0;
    }
  }
  for (size_t c = 0; c < z_.size(); ++c) {
    if (std::isnan(z_[c])) continue;
    const double x = origin_ + (static_cast<int>(c % n_) + 0.5) * cell_;
    const double y = origin_ + (static_cast<int>(c / n_) + 0.5) * cell_;
    if (z_[c] - (plane_.x() * x + plane_.y() * y + plane_.z()) > kMaxAbovePlaneM) {
      z_[c] = std::numeric_limits<float>::quiet_NaN();
      --measured_;
    }
  }
}

double GroundGrid::Height(double x, double y) const {
  if (n_ == 0) return 0.0;
  // Bilinear between cell centres.
  const double fx = std::clamp((x - origin_) / cell_ - 0.5, 0.0, n_ - 1.0);
  const double fy = std::clamp((y - origin_) / cell_ - 0.5, 0.0, n_ - 1.0);
  const int i = std::min(static_cast<int>(fx), n_ - 2), j = std::min(static_cast<int>(fy), n_ - 2);
  const double u = fx - i, v = fy - j;
  auto at = [&](int a, int b) {
    const float z = z_[static_cast<size_t>(b) * n_ + a];
    return std::isnan(z) ? 0.0 : static_cast<double>(z);
  };
  if (n_ < 2) return at(0, 0);
  return (1 - u) * (1 - v) * at(i, j) + u * (1 - v) * at(i + 1, j) + (1 - u) * v * at(i, j + 1) +
         u * v * at(i + 1, j + 1);
}

}  // namespace stemmap::stems
