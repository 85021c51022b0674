#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/sim/scene.h"

namespace stemmap::sim {

struct RenderOptions {
  bool antialias = true;  // extra samples where a stem's side crosses a pixel
  int edge_samples = 4;   // samples added to each such pixel
  double shadow_texel_m = 0.05;
  void Check() const;
};

// What one render produces, before any camera effect (exposure, blur, noise).
struct RenderBuffers {
  cv::Mat radiance;  // CV_32FC3 linear RGB
  cv::Mat depth_m;   // CV_32F distance along the camera z axis; large for sky
};

// Ray-casts a Scene for a pinhole camera. Construction precomputes the sun's shadow map and the
// camera's ray table; Render() is then thread-safe and deterministic.
class Renderer {
 public:
  Renderer(const Scene& scene, const PinholeCamera& camera, const RenderOptions& options);

  RenderBuffers Render(const Rigid3d& world_from_cam) const;

  struct Sample {
    Eigen::Vector3f rgb;
    float t = 0.0f;  // ray length
    int object = 0;  // 0 sky, 1 ground, 2 wall, 3 canopy, 100+ trees, 100000+ shrubs
  };
  // A shrub seen from the frame's ray origin: what its ellipsoid test needs of o, once a frame.
  struct ShrubView {
    Eigen::Vector3d o_scaled, inv_radii;
    double c;
  };
  struct Candidate {
    int index;             // tree index, or -(shrub index + 1)
    double min_dist_xy_m;  // nearest the object can be, horizontally
    double centre_az, half_width;
    const Stem::RayOrigin* origin = nullptr;  // a tree's, from the rays' common origin
    const ShrubView* shrub = nullptr;         // a shrub's, likewise
  };
  // One ray through the scene; `candidates` are the objects that may lie along it, nearest first.
  Sample Trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
               const std::vector<Candidate>& candidates) const;

 private:
  Eigen::Vector3f ShadeSurface(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                               const Eigen::Vector3f& albedo, double occlusion) const;
  double SunVisibility(const Eigen::Vector3d& p) const;
  Eigen::Vector3f Sky(const Eigen::Vector3d& d) const;
  Eigen::Vector3f Wall(const Eigen::Vector3d& p, const Eigen::Vector3d& d) const;
  Eigen::Vector3f GroundAlbedo(double x, double y) const;
  double IntersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max) const;
  ShrubView ViewShrub(int k, const Eigen::Vector3d& o) const;
  bool IntersectShrub(int k, const ShrubView& view, const Eigen::Vector3d& o,
                      const Eigen::Vector3d& d, double t_max, double* t, Eigen::Vector3d* n,
                      Eigen::Vector3f* albedo) const;
  void BuildShadowMap();
  std::vector<Candidate> ColumnCandidates(const Eigen::Vector3d& cam_centre,
                                          const std::vector<Candidate>& objects, double col_az,
                                          double col_half) const;

  const Scene& scene_;
  PinholeCamera camera_;
  RenderOptions options_;
  std::vector<Eigen::Vector3f> cam_rays_;  // unit rays per pixel, camera frame
  // Sun shadow map: distance from the canopy plane along -sun to the first trunk.
  cv::Mat shadow_depth_;
  double shadow_origin_x_ = 0.0, shadow_origin_y_ = 0.0;
  double inv_shadow_texel_ = 1.0, inv_sun_z_ = 1.0;
  // A smooth field tabulated on a grid of square texels and read bilinearly; Read() is false
  // outside it, where the caller evaluates the field itself.
  struct FieldTable {
    double origin_x = 0.0, origin_y = 0.0, texel = 1.0, inv_texel = 1.0;
    cv::Mat values;  // CV_32F, rows along y
    template <typename F>
    static FieldTable Tabulate(double x0, double y0, double texel, int nx, int ny, F&& f);
    // Read per ray: inline, and with products for the divisions.
    bool Read(double x, double y, double* v) const {
      const double gx = (x - origin_x) * inv_texel, gy = (y - origin_y) * inv_texel;
      if (!(gx >= 0.0 && gy >= 0.0 && gx < values.cols - 1 && gy < values.rows - 1)) return false;
      const int j = static_cast<int>(gx), i = static_cast<int>(gy);
      const float* r0 = values.ptr<float>(i) + j;
      const float* r1 = r0 + values.step1();
      const double wx = gx - j, wy = gy - i;
      *v = (1 - wy) * ((1 - wx) * r0[0] + wx * r0[1]) + wy * ((1 - wx) * r1[0] + wx * r1[1]);
      return true;
    }
  };
  void BuildFieldTables(double half_extent_m);
  FieldTable fleck_;         // the crowns' openings, on the crown plane
  FieldTable ground_patch_;  // litter against green patches, on the ground plane
  FieldTable canopy_tint_;   // the foliage's shade, across the crowns
  // The distant forest, unrolled: u = metres along the wall, z = height above the ground.
  FieldTable wall_crown_line_;  // along u only
  FieldTable wall_opening_;
  double wall_radius_m_ = 45.0;
  ValueNoise ground_noise_, canopy_noise_, wall_noise_, leaf_noise_;
};

}  // namespace stemmap::sim
