#include "stemmap/track/rotation.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "stemmap/core/rng.h"

namespace stemmap::track {

Eigen::Matrix3d FitRotation(const std::vector<Eigen::Vector3d>& a,
                            const std::vector<Eigen::Vector3d>& b) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) h += b[i] * a[i].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

RotationFit FitRotationRansac(const std::vector<Eigen::Vector3d>& a,
                              const std::vector<Eigen::Vector3d>& b, double threshold_rad,
                              int iterations, uint64_t seed) {
  RotationFit best;
  const int n = static_cast<int>(a.size());
  if (n < 2) return best;
  const double cos_thr = std::cos(threshold_rad);
  auto inliers_of = [&](const Eigen::Matrix3d& r) {
    std::vector<int> in;
    for (int i = 0; i < n; ++i) {
      if (b[i].dot(r * a[i]) >= cos_thr) in.push_back(i);
    }
    return in;
  };
  Rng rng(seed);
  for (int it = 0; it < iterations; ++it) {
    const int i = rng.UniformInt(0, n - 1), j = rng.UniformInt(0, n - 1);
    if (i == j || a[i].cross(a[j]).norm() < 1e-3) continue;
    const Eigen::Matrix3d r = FitRotation({a[i], a[j]}, {b[i], b[j]});
    std::vector<int> in = inliers_of(r);
    if (in.size() > best.inliers.size()) best = {r, std::move(in)};
  }
  for (int refine = 0; refine < 2 && best.inliers.size() >= 3; ++refine) {
    std::vector<Eigen::Vector3d> ia, ib;
    for (int i : best.inliers) {
      ia.push_back(a[i]);
      ib.push_back(b[i]);
    }
    best.b_from_a = FitRotation(ia, ib);
    best.inliers = inliers_of(best.b_from_a);
  }
  return best;
}

double YawOfRotation(const Eigen::Matrix3d& r) { return std::atan2(r(0, 2), r(0, 0)); }

std::vector<double> ApparentTurnIncrements(const FrontendResult& f, const PinholeCamera& camera,
                                           double percentile, int min_shared_points) {
  const size_t n = f.keyframes.size();
  std::vector<std::vector<double>> d(n);
  for (const Track& t : f.tracks) {
    for (size_t k = 1; k < t.obs.size(); ++k) {
      const Observation &o0 = t.obs[k - 1], &o1 = t.obs[k];
      if (o1.keyframe != o0.keyframe + 1) continue;
      const Eigen::Vector3d r0 = camera.CamRayFromImage(o0.px), r1 = camera.CamRayFromImage(o1.px);
      d[o1.keyframe].push_back(std::atan(r1.x()) - std::atan(r0.x()));
    }
  }
  std::vector<double> out(n, 0.0);
  for (size_t k = 1; k < n; ++k) {
    std::vector<double>& v = d[k];
    if (static_cast<int>(v.size()) < min_shared_points) {
      out[k] = std::nan("");
      continue;
    }
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const double sign = v[v.size() / 2] >= 0 ? 1.0 : -1.0;
    for (double& x : v) x *= sign;
    const size_t q = static_cast<size_t>(percentile * (v.size() - 1));
    std::nth_element(v.begin(), v.begin() + q, v.end());
    out[k] = sign * v[q];
  }
  return out;
}

}  // namespace stemmap::track
