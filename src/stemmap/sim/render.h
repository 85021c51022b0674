#pragma once

#include <opencv2/core.hpp>
#include <optional>
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

// What the wind moves at one instant (stand frame); empty vectors leave everything at rest.
struct SceneSway {
  std::vector<Eigen::Vector3d> shrub_offset_m;  // per shrub: its shift, leaves and all
  std::vector<Eigen::Quaterniond> tree_tilt;    // per tree: a turn about its stem's base
  Eigen::Vector3d crown_offset_m = Eigen::Vector3d::Zero();  // the foliage layer's shift
};

// One frame as a phone takes it: the rows' poses (a rolling shutter), this frame's intrinsics
// (focus breathing, a stabilising crop) and the scene's sway. The defaults are a global shutter
// at the renderer's camera, in still air.
struct FrameSetup {
  Rigid3d world_from_cam;                   // the frame's pose; every row's where the next is empty
  std::vector<Rigid3d> world_from_row_cam;  // row v seen from world_from_row_cam[v] (height poses)
  std::optional<PinholeCamera> camera;      // same size as the renderer's
  SceneSway sway;
};

// Ray-casts a Scene for a pinhole camera. Construction precomputes the sun's shadow map and the
// camera's ray table; Render() is then thread-safe and deterministic.
class Renderer {
 public:
  Renderer(const Scene& scene, const PinholeCamera& camera, const RenderOptions& options);

  // A global shutter at the renderer's camera, the scene at rest.
  RenderBuffers Render(const Rigid3d& world_from_cam) const;
  RenderBuffers Render(const FrameSetup& frame) const;
  // Median depth (m, along the camera z) of a grid of `samples` x `samples` rays over the middle
  // `window` share of the image's width and height, seen from the frame's pose: what an
  // autofocus meters. Sky counts as far.
  double CentreDepth(const FrameSetup& frame, double window = 0.1, int samples = 9) const;

  struct Sample {
    Eigen::Vector3f rgb;
    float t = 0.0f;  // ray length
    int object = 0;  // 0 sky, 1 ground, 2 wall, 3 canopy, 100+ trees, 100000+ shrubs
  };
  // A shrub seen from the frame's ray origin: what its ellipsoid test needs of o, once a frame.
  struct ShrubView {
    Eigen::Vector3d o_scaled, inv_radii;
    double c;
    Eigen::Vector3d leaf_offset;  // where the shrub reads the leaf noise, less its sway
  };
  struct Candidate {
    int index;             // tree index, or -(shrub index + 1)
    double min_dist_xy_m;  // nearest the object can be, horizontally
    double centre_az, half_width;
    int view = -1;  // its view from the rays' origin in the TraceContext's table, or none
    // A tree the wind tilts: the turn from the world to the stem at rest (about its base).
    const Eigen::Matrix3d* rest_from_world = nullptr;
  };
  // What the rays from one origin share: each candidate's view of that origin (by
  // Candidate::view; without them, views are made per ray), and the crowns' sway.
  struct TraceContext {
    const Stem::RayOrigin* trees = nullptr;
    const ShrubView* shrubs = nullptr;
    Eigen::Vector3d crown_offset_m = Eigen::Vector3d::Zero();
  };
  // One ray through the scene; `candidates` are the objects that may lie along it, nearest first.
  Sample Trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
               const std::vector<Candidate>& candidates, const TraceContext& context) const;

 private:
  Eigen::Vector3f ShadeSurface(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                               const Eigen::Vector3f& albedo, double occlusion) const;
  double SunVisibility(const Eigen::Vector3d& p) const;
  Eigen::Vector3f Sky(const Eigen::Vector3d& d) const;
  Eigen::Vector3f Wall(const Eigen::Vector3d& p, const Eigen::Vector3d& d) const;
  Eigen::Vector3f GroundAlbedo(double x, double y) const;
  double IntersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max) const;
  ShrubView ViewShrub(int k, const Eigen::Vector3d& o,
                      const Eigen::Vector3d& offset_m = Eigen::Vector3d::Zero()) const;
  bool IntersectShrub(int k, const ShrubView& view, const Eigen::Vector3d& o,
                      const Eigen::Vector3d& d, double t_max, double* t, Eigen::Vector3d* n,
                      Eigen::Vector3f* albedo) const;
  void BuildShadowMap();
  std::vector<Candidate> ColumnCandidates(const Eigen::Vector3d& cam_centre,
                                          const std::vector<Candidate>& objects, double col_az,
                                          double col_half) const;
  // The objects one frame may show, seen from around `o` (within `reach_m`: a rolling shutter's
  // rows move the origin), with what their views of an origin need.
  struct FrameObjects {
    std::vector<Candidate> objects;                // nearest first
    std::vector<int> tree_of_view;                 // per tree view: the tree
    std::vector<int> view_of_tree;                 // per tree: its view, or -1
    std::vector<Eigen::Matrix3d> rest_from_world;  // per tree view (identity at rest)
    std::vector<int> shrub_of_view;                // per shrub view: the shrub
    std::vector<Eigen::Vector3d> shrub_offset_m;   // per shrub view
    Eigen::Vector3d crown_offset_m = Eigen::Vector3d::Zero();
  };
  FrameObjects FindObjects(const Eigen::Vector3d& o, const Eigen::Matrix3d& rot,
                           const PinholeCamera& cam, double reach_m, double turn_rad,
                           const SceneSway& sway) const;
  // Each image column's candidates, nearest first: the objects within the azimuths its rays span
  // (widened by the rows' turn `turn_rad` from the frame's rotation).
  std::vector<std::vector<Candidate>> ColumnLists(const FrameObjects& objects,
                                                  const Eigen::Vector3d& o,
                                                  const Eigen::Matrix3d& rot,
                                                  const std::vector<Eigen::Vector3f>& cam_rays,
                                                  const PinholeCamera& cam, double turn_rad) const;
  // Fills the views of origin o (sized as the frame's tables) and returns the context for it.
  TraceContext ViewFrom(const FrameObjects& frame, const Eigen::Vector3d& o,
                        Stem::RayOrigin* tree_views, ShrubView* shrub_views) const;
  // Unit rays per pixel in the camera frame.
  static std::vector<Eigen::Vector3f> CamRays(const PinholeCamera& cam);

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
