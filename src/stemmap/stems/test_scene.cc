#include "stemmap/stems/test_scene.h"

#include <Eigen/Geometry>
#include <cmath>

#include "stemmap/core/noise.h"

namespace stemmap::stems {
namespace {

const ValueNoise& LeafNoise() {
  static const ValueNoise noise(11);
  return noise;
}

}  // namespace

double HitLeafClump(const LeafClump& clump, const Eigen::Vector3d& origin,
                    const Eigen::Vector3d& dir) {
  // The ellipsoid scaled to the unit sphere: the ray's point at t is os + t ds there.
  const Eigen::Vector3d inv = clump.radii_m.cwiseInverse();
  const Eigen::Vector3d os = (origin - clump.centre).cwiseProduct(inv);
  const Eigen::Vector3d ds = dir.cwiseProduct(inv);
  const double a = ds.squaredNorm(), b = os.dot(ds), c = os.squaredNorm() - 1.0;
  const double disc = b * b - a * c;
  if (disc <= 0) return -1;
  const double t0 = std::max((-b - std::sqrt(disc)) / a, 1e-3);
  const double t1 = (-b + std::sqrt(disc)) / a;
  const ValueNoise& leaf = LeafNoise();
  const double threshold = 1.05 - 0.6 * clump.density;
  // Steps of 1.5 cm through leaves about 5 cm across.
  for (double t = t0; t < t1; t += 0.015) {
    const Eigen::Vector3d p = origin + t * dir;
    const double centre = 0.6 * (1.0 - (os + t * ds).norm());
    const double v = leaf.Noise3(p.x() * 18.0, p.y() * 18.0, p.z() * 18.0) + centre - 0.2;
    if (v > threshold) return t;
  }
  return -1;
}

RenderedStem RenderStems(const std::vector<Eigen::Vector3d>& stems, bool textured_background,
                         bool sunlit, Texture texture, const PinholeCamera& camera,
                         const std::vector<LeafClump>& clumps, double sky_luma) {
  RenderedStem r;
  r.camera = camera;
  const ValueNoise noise(7);
  for (int k = 0; k < 34; ++k) {
    const double th = (-30.0 + 2.0 * k) * M_PI / 180.0;
    Eigen::Matrix3d rot;  // columns: camera x (right), y (down), z (forward) in the plot frame
    rot << std::sin(th), 0, std::cos(th), -std::cos(th), 0, std::sin(th), 0, -1, 0;
    Rigid3d world_from_cam{Eigen::Quaterniond(rot),
                           Eigen::Vector3d(std::cos(th), std::sin(th), 1.3)};
    cv::Mat img(r.camera.height, r.camera.width, CV_8U);
    for (int y = 0; y < img.rows; ++y) {
      for (int x = 0; x < img.cols; ++x) {
        const Eigen::Vector3d ray = world_from_cam.rotation * r.camera.CamRayFromImage({x, y});
        const Eigen::Vector2d u = ray.head<2>();
        double luma = sky_luma >= 0 ? sky_luma : (sunlit ? 130 : 210), nearest = 1e9;  // sky
        for (size_t i = 0; i < stems.size(); ++i) {
          const Eigen::Vector2d q = world_from_cam.translation.head<2>() - stems[i].head<2>();
          const double a = u.squaredNorm(), b = q.dot(u),
                       c = q.squaredNorm() - stems[i].z() * stems[i].z();
          if (b * b - a * c < 0) continue;
          const double t = (-b - std::sqrt(b * b - a * c)) / a;
          if (t <= 0 || t >= nearest) continue;
          nearest = t;
          const Eigen::Vector2d hit = q + t * u;
          const double az = std::atan2(hit.y(), hit.x());
          luma = 80 + 40 * i;
          if (texture == Texture::kRegular) luma += 25 * std::sin(40 * az);
          if (texture == Texture::kIrregular || texture == Texture::kLimbShaded ||
              texture == Texture::kNoisyBark) {
            // Bark pieces about 3 cm across and 5 cm high.
            const double z = world_from_cam.translation.z() + t * ray.z();
            const double contrast = texture == Texture::kNoisyBark ? 20 : 40;
            luma += contrast * noise.Noise2(stems[i].z() * (az + M_PI) / 0.03 + 100 * i, z / 0.05);
          }
          const double facing = -hit.normalized().dot(stems[i].head<2>().normalized());
          if (texture == Texture::kLimbShaded && facing < std::cos(50 * M_PI / 180)) luma -= 60;
          if (texture == Texture::kNoisyBark) luma += 40 * noise.Noise3(0.5 * x, 0.5 * y, 7.3 * k);
          if (sunlit)
            luma = 70 + 130 * std::sqrt(std::max(0.0, hit.normalized().y())) + 0.4 * (luma - 80);
        }
        // Leaves in front of every stem (distances along the unit ray, `nearest` along `ray`).
        const double ray_norm = ray.norm();
        for (const LeafClump& clump : clumps) {
          const Eigen::Vector3d o = world_from_cam.translation, d = ray / ray_norm;
          const double t = HitLeafClump(clump, o, d);
          if (t < 0 || t / ray_norm >= nearest) continue;
          nearest = t / ray_norm;
          const Eigen::Vector3d p = o + t * d;
          luma = 70 + 30 * LeafNoise().Noise3(p.x() * 40.0, p.y() * 40.0, p.z() * 40.0);
        }
        if (nearest > 1e8 && textured_background) {
          const double az = std::atan2(u.y(), u.x());
          const double elevation = ray.z() / u.norm();
          luma = texture == Texture::kIrregular || texture == Texture::kLimbShaded ||
                         texture == Texture::kNoisyBark
                     ? 150 + 60 * noise.Noise2(az * 250.0 + 300.0, elevation * 60.0)
                     : 150 + 50 * std::sin(400 * az) * std::cos(30 * elevation);
        }
        img.at<uchar>(y, x) = cv::saturate_cast<uchar>(luma);
      }
    }
    r.keyframes.push_back({0.1 * k, world_from_cam});
    r.gray.push_back(img);
  }
  return r;
}

}  // namespace stemmap::stems
