#include "stemmap/track/refine_observations.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>

#include "stemmap/core/error.h"

namespace stemmap::track {

void RefineObservationsOptions::Check() const {
  if (window_px < 3 || window_px % 2 == 0) {
    throw InputError("observation refinement: the window must be odd and at least 3 px");
  }
  if (max_iterations < 1 || !(max_shift_px > 0) || !(min_ncc > -1 && min_ncc < 1)) {
    throw InputError("observation refinement: iterations, shift and agreement out of range");
  }
}

std::string RefineObservationsSummary::BriefReport() const {
  return fmt::format("{} of {} observations moved, mean {:.3f} px", moved, observations,
                     mean_shift_px);
}

namespace {

// Bilinear grey level at (x, y); the caller keeps (x, y) at least one pixel inside.
double Sample(const cv::Mat& img, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const uchar* r0 = img.ptr<uchar>(y0) + x0;
  const uchar* r1 = img.ptr<uchar>(y0 + 1) + x0;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

bool Inside(const cv::Mat& img, const Eigen::Vector2d& p, double reach) {
  return p.x() - reach >= 1.0 && p.y() - reach >= 1.0 && p.x() + reach < img.cols - 2.0 &&
         p.y() + reach < img.rows - 2.0;
}

// Pixel of a world point in keyframe k under the map's focal scale, which applies to what the
// lens gives (ReprojectionError).
bool Project(const SparseMap& map, const PinholeCamera& camera, int k, const Eigen::Vector3d& x,
             Eigen::Vector2d* px) {
  const Eigen::Vector3d p = map.cam_from_world[k] * (x - map.centre_world[k]);
  if (p.z() <= 1e-3) return false;
  if (camera.HasDistortion()) {
    const Eigen::Vector2d centre(camera.cx, camera.cy);
    *px = centre + map.focal_scale * (camera.ImageFromCam(p) - centre);
    return true;
  }
  const Eigen::Vector2d n = map.focal_scale * p.head<2>() / p.z();
  *px = camera.ImageFromCam(Eigen::Vector3d(n.x(), n.y(), 1.0));
  return true;
}

}  // namespace

bool LocalPatchWarp(const SparseMap& map, const PinholeCamera& camera, int ref, int kf,
                    const Eigen::Vector3d& x_world, Eigen::Matrix2d* ref_to_kf) {
  // Two small steps in the plane through the point, normal to the reference ray: their images in
  // both views give each view's 2x2 Jacobian of pixel over step; the warp is one over the other.
  const Eigen::Vector3d ray = x_world - map.centre_world[ref];
  const double range = ray.norm();
  if (range < 1e-6) return false;
  const Eigen::Vector3d n = ray / range;
  Eigen::Vector3d e1 = n.cross(Eigen::Vector3d::UnitZ());
  if (e1.norm() < 1e-6) e1 = n.cross(Eigen::Vector3d::UnitX());
  e1.normalize();
  const Eigen::Vector3d e2 = n.cross(e1);
  const double step = 1e-4 * range;
  Eigen::Vector2d r0, r1, r2, k0, k1, k2;
  if (!Project(map, camera, ref, x_world, &r0) || !Project(map, camera, kf, x_world, &k0) ||
      !Project(map, camera, ref, x_world + step * e1, &r1) ||
      !Project(map, camera, ref, x_world + step * e2, &r2) ||
      !Project(map, camera, kf, x_world + step * e1, &k1) ||
      !Project(map, camera, kf, x_world + step * e2, &k2)) {
    return false;
  }
  Eigen::Matrix2d jr, jk;
  jr << r1 - r0, r2 - r0;
  jk << k1 - k0, k2 - k0;
  if (std::abs(jr.determinant()) < 1e-12) return false;
  *ref_to_kf = jk * jr.inverse();
  return ref_to_kf->allFinite();
}

bool AlignPatch(const RefineObservationsOptions& o, const cv::Mat& reference,
                const Eigen::Vector2d& ref_px, const cv::Mat& image, const Eigen::Matrix2d& a,
                Eigen::Vector2d* px, double* ncc) {
  const int half = o.window_px / 2;
  const int n = o.window_px * o.window_px;
  if (!Inside(reference, ref_px, half + 1)) return false;
  const double reach = (a.cwiseAbs() * Eigen::Vector2d::Constant(half)).maxCoeff() + 1.0;
  std::vector<Eigen::Vector2d> offsets;
  std::vector<double> ref(n);
  offsets.reserve(n);
  double ref_mean = 0, grad = 0;
  for (int j = -half, i = 0; j <= half; ++j) {
    for (int k = -half; k <= half; ++k, ++i) {
      offsets.emplace_back(k, j);
      const double x = ref_px.x() + k, y = ref_px.y() + j;
      ref[i] = Sample(reference, x, y);
      ref_mean += ref[i];
      grad += 0.5 * (std::abs(Sample(reference, x + 1, y) - Sample(reference, x - 1, y)) +
                     std::abs(Sample(reference, x, y + 1) - Sample(reference, x, y - 1)));
    }
  }
  ref_mean /= n;
  if (grad / n < o.min_gradient) return false;
  // Model: image(p + a d) = gain * ref(d) + offset; Gauss-Newton in (p, gain, offset).
  Eigen::Vector2d p = *px;
  double gain = 1.0, offset = 0.0;
  std::vector<double> cur(n);
  for (int it = 0; it < o.max_iterations; ++it) {
    if (!Inside(image, p, reach + 1.0)) return false;
    Eigen::Matrix4d h = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d q = p + a * offsets[i];
      cur[i] = Sample(image, q.x(), q.y());
      const double gx = 0.5 * (Sample(image, q.x() + 1, q.y()) - Sample(image, q.x() - 1, q.y()));
      const double gy = 0.5 * (Sample(image, q.x(), q.y() + 1) - Sample(image, q.x(), q.y() - 1));
      const Eigen::Vector4d jac(gx, gy, -ref[i], -1.0);
      const double e = cur[i] - gain * ref[i] - offset;
      h += jac * jac.transpose();
      g += jac * e;
    }
    const Eigen::Vector4d step = -h.ldlt().solve(g);
    if (!step.allFinite()) return false;
    p += step.head<2>();
    gain += step(2);
    offset += step(3);
    if (step.head<2>().norm() < 0.005) break;
  }
  if (!Inside(image, p, reach + 1.0)) return false;
  double cur_mean = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d q = p + a * offsets[i];
    cur[i] = Sample(image, q.x(), q.y());
    cur_mean += cur[i];
  }
  cur_mean /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (int i = 0; i < n; ++i) {
    sab += (cur[i] - cur_mean) * (ref[i] - ref_mean);
    saa += (cur[i] - cur_mean) * (cur[i] - cur_mean);
    sbb += (ref[i] - ref_mean) * (ref[i] - ref_mean);
  }
  if (saa <= 0 || sbb <= 0) return false;
  *ncc = sab / std::sqrt(saa * sbb);
  *px = p;
  return true;
}

RefineObservationsSummary RefineKeyframeObservations(const RefineObservationsOptions& o,
                                                     const std::vector<cv::Mat>& gray,
                                                     const PinholeCamera& camera,
                                                     const SparseMap& map,
                                                     std::vector<Track>* tracks) {
  o.Check();
  RefineObservationsSummary s;
  const int n_tracks = static_cast<int>(tracks->size());
  std::vector<int> considered(n_tracks, 0), moved(n_tracks, 0);
  std::vector<double> shift(n_tracks, 0.0);
  // Tracks are independent: each thread writes only its own tracks' observations.
#pragma omp parallel for schedule(dynamic, 64)
  for (int t = 0; t < n_tracks; ++t) {
    if (t >= static_cast<int>(map.point_valid.size()) || !map.point_valid[t]) continue;
    std::vector<Observation>& obs = (*tracks)[t].obs;
    std::vector<int> valid;
    for (size_t k = 0; k < obs.size(); ++k) {
      if (map.obs_valid[t][k]) valid.push_back(static_cast<int>(k));
    }
    if (valid.size() < 2) continue;
    const Observation ref = obs[valid[valid.size() / 2]];
    const cv::Mat& ref_img = gray[ref.keyframe];
    if (ref_img.empty()) continue;
    for (int k : valid) {
      Observation& ob = obs[k];
      if (ob.keyframe == ref.keyframe || gray[ob.keyframe].empty()) continue;

      ++considered[t];
      Eigen::Matrix2d a;
      if (!LocalPatchWarp(map, camera, ref.keyframe, ob.keyframe, map.point_world[t], &a)) {
        continue;
      }
      // Matched where the pictures show the point (a rolling shutter shifts each row), then
      // moved to the frame's time by the observation's own shift.
      Eigen::Vector2d px = ob.px + ob.picture_offset_px;
      double ncc = 0;
      if (!AlignPatch(o, ref_img, ref.px + ref.picture_offset_px, gray[ob.keyframe], a, &px,
                      &ncc)) {
        continue;
      }
      px -= ob.picture_offset_px;
      const double d = (px - ob.px).norm();
      if (ncc < o.min_ncc || d > o.max_shift_px) continue;
      ob.px = px;
      ++moved[t];
      shift[t] += d;
    }
  }
  double shift_sum = 0;
  for (int t = 0; t < n_tracks; ++t) {
    s.observations += considered[t];
    s.moved += moved[t];
    shift_sum += shift[t];
  }
  s.mean_shift_px = s.moved > 0 ? shift_sum / s.moved : 0.0;
  return s;
}

void CarryCorrectionsToFrames(const std::vector<Track>& before, const std::vector<Track>& after,
                              const std::vector<Keyframe>& keyframes,
                              std::vector<FrameObservations>* between) {
  for (FrameObservations& b : *between) {
    for (size_t i = 0; i < b.track.size(); ++i) {
      const std::vector<Observation>& was = before[b.track[i]].obs;
      const std::vector<Observation>& now = after[b.track[i]].obs;
      // The track's last keyframe observation at or before this frame, and the one after it.
      size_t next = 0;
      while (next < was.size() && keyframes[was[next].keyframe].frame <= b.frame) ++next;
      Eigen::Vector2d correction = Eigen::Vector2d::Zero();
      if (next == 0 && next < was.size()) {
        correction = now[next].px - was[next].px;
      } else if (next == was.size() && next > 0) {
        correction = now[next - 1].px - was[next - 1].px;
      } else if (next > 0) {
        const double f0 = keyframes[was[next - 1].keyframe].frame;
        const double f1 = keyframes[was[next].keyframe].frame;
        const double w = f1 > f0 ? (b.frame - f0) / (f1 - f0) : 0.0;
        correction =
            (1 - w) * (now[next - 1].px - was[next - 1].px) + w * (now[next].px - was[next].px);
      }
      b.px[i] += correction.cast<float>();
    }
  }
}

}  // namespace stemmap::track
