// Per-frame ray casting: candidate culling per image column, tracing, and edge antialiasing.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "stemmap/core/fast_math.h"
#include "stemmap/core/units.h"
#include "stemmap/sim/render.h"

namespace stemmap::sim {

namespace {

constexpr int kObjSky = 0, kObjGround = 1, kObjWall = 2, kObjCanopy = 3, kObjTree = 100,
              kObjShrub = 100000;

}  // namespace

Renderer::Sample Renderer::Trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                 const std::vector<Candidate>& candidates,
                                 const TraceContext& context) const {
  Sample s;
  const double dxy = std::sqrt(d.x() * d.x() + d.y() * d.y());
  // Where the ray leaves the modelled scene through the distant-forest wall.
  double t_wall = kInf;
  if (dxy > 1e-9) {
    const double a = d.x() * d.x() + d.y() * d.y();
    const double b = o.x() * d.x() + o.y() * d.y();
    const double c = o.x() * o.x() + o.y() * o.y() - wall_radius_m_ * wall_radius_m_;
    t_wall = (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a;
  }
  // Objects first, the ground after and only up to the nearest object: marching the ground
  // behind a trunk is wasted. A descending ray meets the ground no later than the slab bottom,
  // which bounds the object search for rays that hit the ground near the camera.
  const Ground& g = scene_.ground;
  double t_ground_max = t_wall;
  const double below = o.z() - g.PlaneHeight(o.x(), o.y()) + g.BumpBound();
  const double closing = g.plane_gradient().dot(d.head<2>()) - d.z();
  if (closing > 0) t_ground_max = std::min(t_ground_max, std::max(below, 0.0) / closing);
  double t_best = kInf;
  int object = kObjSky;
  Eigen::Vector3d normal(0, 0, 1);
  Eigen::Vector3f albedo(0, 0, 0);
  // A stem is shaded once the nearest is known: a nearer one found later hides it.
  Stem::SurfacePoint stem_point;
  const Eigen::Matrix3d* stem_rest_from_world = nullptr;
  for (const Candidate& c : candidates) {
    const double t_limit = std::min(t_best, t_ground_max);
    if (c.min_dist_xy_m > t_limit * dxy + 1e-6) break;
    if (c.index >= 0) {
      const Stem& stem = scene_.trees[c.index].stem;
      const double tol = 0.25 / camera_.fx;
      std::optional<Stem::SurfacePoint> point;
      if (c.view < 0 || !context.trees) {
        point = stem.FirstSurfacePoint(o, d, 1e-4, t_limit, tol);
      } else if (c.rest_from_world) {
        // A tilted stem meets the ray turned back into its rest pose: the same t, as the turn
        // about the base is rigid (the view's origin was turned likewise).
        point = stem.FirstSurfacePoint(context.trees[c.view], *c.rest_from_world * d, 1e-4, t_limit,
                                       tol);
      } else {
        point = stem.FirstSurfacePoint(context.trees[c.view], d, 1e-4, t_limit, tol);
      }
      if (point) {
        t_best = point->t;
        object = kObjTree + c.index;
        stem_point = *point;
        stem_rest_from_world = c.rest_from_world;
      }
    } else {
      double t;
      Eigen::Vector3d n;
      Eigen::Vector3f a;
      const int k = -c.index - 1;
      const bool hit = c.view >= 0 && context.shrubs
                           ? IntersectShrub(k, context.shrubs[c.view], o, d, t_limit, &t, &n, &a)
                           : IntersectShrub(k, ViewShrub(k, o), o, d, t_limit, &t, &n, &a);
      if (hit) {
        t_best = t;
        object = kObjShrub + (-c.index - 1);
        normal = n;
        albedo = a;
      }
    }
  }

  const double t_ground = IntersectGround(o, d, std::min(t_best, t_wall));
  if (t_ground < t_best) {
    t_best = t_ground;
    object = kObjGround;
  } else if (object >= kObjTree && object < kObjShrub) {
    const StemHit hit = scene_.trees[object - kObjTree].stem.Shade(stem_point);
    normal = stem_rest_from_world
                 ? Eigen::Vector3d(stem_rest_from_world->transpose() * hit.normal_world)
                 : hit.normal_world;
    albedo = hit.albedo;
  }

  Eigen::Vector3f rgb;
  double t_end = t_best;
  if (object == kObjGround) {
    const Eigen::Vector3d p = o + t_best * d;
    rgb = ShadeSurface(p, scene_.ground.Normal(p.x(), p.y()), GroundAlbedo(p.x(), p.y()), 1.0);
  } else if (object != kObjSky) {
    const Eigen::Vector3d p = o + t_best * d;
    rgb = ShadeSurface(p, normal, albedo, object >= kObjShrub ? 0.6 : 0.9);
  } else if (t_wall < kInf) {
    object = kObjWall;
    t_end = t_wall;
    rgb = Wall(o + t_wall * d, d);
  } else {
    rgb = Sky(d);
    t_end = 1e4;
  }

  // Foliage between the camera and whatever the ray reached above the crown base.
  const Lighting& L = scene_.light;
  if (d.z() > 1e-4) {
    const double tc0 = (L.canopy_base_m - o.z()) / d.z();
    if (tc0 < t_end) {
      const double tc1 = std::min(t_end, (L.canopy_top_m - o.z()) / d.z());
      const double step = std::max(1.3 / d.z(), 1.3);
      const double th = (L.canopy_cover - 0.5) * -0.8;
      const Eigen::Vector3f leaf = Eigen::Vector3f(0.018f, 0.034f, 0.012f)
                                       .cwiseProduct(L.sky_rgb * 1.3f + L.sun_rgb * 0.15f);
      double transmit = 1.0;
      Eigen::Vector3f acc(0, 0, 0);
      for (double t = tc0; t < tc1 && transmit > 0.02; t += step) {
        const Eigen::Vector3d p = o + t * d - context.crown_offset_m;  // the crowns at rest
        const double v = canopy_noise_.Fbm3(p.x() / 3.5, p.y() / 3.5, p.z() / 2.5, 2);
        const double alpha = std::clamp((v - th) * 8.0, 0.0, 0.97);
        if (alpha > 0) {
          double shade;
          if (!canopy_tint_.Read(p.x(), p.y(), &shade))
            shade = canopy_noise_.Noise3(p.x(), p.y(), 3.3);
          const float tint = static_cast<float>(0.8 + 0.4 * shade);
          acc += leaf * static_cast<float>(transmit * alpha) * tint;
          transmit *= 1.0 - alpha;
          if (transmit < 0.5 && object != kObjCanopy && t < t_end) {
            object = kObjCanopy;
            t_end = t;
          }
        }
      }
      rgb = acc + rgb * static_cast<float>(transmit);
    }
  }
  // Aerial perspective: distant things fade toward a bright haze.
  const double haze = object == kObjSky ? 0.0 : 1.0 - ExpNeg(std::min(t_end * dxy, 400.0) / 400.0);
  rgb = rgb * static_cast<float>(1.0 - haze) +
        Eigen::Vector3f(0.7f, 0.8f, 0.9f) * static_cast<float>(haze);
  s.rgb = rgb;
  s.t = static_cast<float>(t_end);
  s.object = object;
  return s;
}

RenderBuffers Renderer::Render(const FrameSetup& frame) const {
  const int w = camera_.width, h = camera_.height;
  const bool own_camera = frame.camera.has_value();
  const PinholeCamera& cam = own_camera ? *frame.camera : camera_;
  if (cam.width != w || cam.height != h) {
    throw std::invalid_argument("render: the frame's camera differs in size from the renderer's");
  }
  const bool rolling = !frame.world_from_row_cam.empty();
  if (rolling && static_cast<int>(frame.world_from_row_cam.size()) != h) {
    throw std::invalid_argument("render: a rolling shutter needs one pose per image row");
  }
  std::vector<Eigen::Vector3f> own_rays;
  if (own_camera) own_rays = CamRays(cam);
  const std::vector<Eigen::Vector3f>& cam_rays = own_camera ? own_rays : cam_rays_;
  const Eigen::Matrix3d rot = frame.world_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d o = frame.world_from_cam.translation;

  // A rolling shutter: each row from its own pose, all near the frame's. The objects are found
  // from the frame's pose, widened by how far the rows' origins and rotations stray from it.
  std::vector<Eigen::Matrix3d> row_rot;
  std::vector<Eigen::Vector3d> row_o;
  double reach_m = 0.0, turn_rad = 0.0;
  if (rolling) {
    row_rot.resize(h);
    row_o.resize(h);
    for (int v = 0; v < h; ++v) {
      const Rigid3d& pose = frame.world_from_row_cam[v];
      row_rot[v] = pose.rotation.toRotationMatrix();
      row_o[v] = pose.translation;
      reach_m = std::max(reach_m, (pose.translation - o).norm());
      turn_rad = std::max(turn_rad, pose.rotation.angularDistance(frame.world_from_cam.rotation));
    }
  }
  const FrameObjects objects = FindObjects(o, rot, cam, reach_m, turn_rad, frame.sway);
  // The objects' views of the rays' origin: one table for the frame, or one per row.
  const size_t n_tree_views = objects.tree_of_view.size();
  const size_t n_shrub_views = objects.shrub_of_view.size();
  const int n_origins = rolling ? h : 1;
  std::vector<Stem::RayOrigin> tree_views(n_tree_views * n_origins);
  std::vector<ShrubView> shrub_views(n_shrub_views * n_origins);
  std::vector<TraceContext> contexts(n_origins);
#pragma omp parallel for schedule(static) if (rolling)
  for (int r = 0; r < n_origins; ++r) {
    contexts[r] = ViewFrom(objects, rolling ? row_o[r] : o, tree_views.data() + r * n_tree_views,
                           shrub_views.data() + r * n_shrub_views);
  }
  const auto row_rotation = [&](int v) -> const Eigen::Matrix3d& {
    return rolling ? row_rot[v] : rot;
  };
  const auto row_origin = [&](int v) -> const Eigen::Vector3d& { return rolling ? row_o[v] : o; };
  const auto row_context = [&](int v) -> const TraceContext& { return contexts[rolling ? v : 0]; };
  // Whether a ray of row v meets tree i.
  auto hits_tree = [&](int i, const Eigen::Vector3d& d, int v) {
    const Stem& stem = scene_.trees[i].stem;
    const double tol = 0.25 / camera_.fx;
    const int view = objects.view_of_tree[i];
    if (view < 0) return stem.FirstSurfacePoint(row_origin(v), d, 1e-4, kInf, tol).has_value();
    const Stem::RayOrigin& origin = row_context(v).trees[view];
    const Eigen::Matrix3d& rest = objects.rest_from_world[view];
    return (rest.isIdentity(0.0)
                ? stem.FirstSurfacePoint(origin, d, 1e-4, kInf, tol)
                : stem.FirstSurfacePoint(origin, Eigen::Vector3d(rest * d), 1e-4, kInf, tol))
        .has_value();
  };

  const std::vector<std::vector<Candidate>> columns =
      ColumnLists(objects, o, rot, cam_rays, cam, turn_rad);

  RenderBuffers out;
  out.radiance = cv::Mat(h, w, CV_32FC3);
  out.depth_m = cv::Mat(h, w, CV_32F);
  cv::Mat ids(h, w, CV_32S);
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v) {
    auto* rad = out.radiance.ptr<cv::Vec3f>(v);
    auto* dep = out.depth_m.ptr<float>(v);
    auto* id = ids.ptr<int>(v);
    const Eigen::Matrix3d& rot_v = row_rotation(v);
    const Eigen::Vector3d& o_v = row_origin(v);
    const TraceContext& context = row_context(v);
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3f& rc = cam_rays[static_cast<size_t>(v) * w + u];
      const Sample s = Trace(o_v, rot_v * rc.cast<double>(), columns[u], context);
      rad[u] = cv::Vec3f(s.rgb.x(), s.rgb.y(), s.rgb.z());
      dep[u] = s.t * rc.z();
      id[u] = s.object;
    }
  }
  if (!options_.antialias || options_.edge_samples == 0) return out;

  // A stem side between pixel centres u and u + 1 lies in the footprint of one of the two: a ray
  // through their common border (u + 0.5) tells which, and only that pixel gets extra samples
  // (on a rotated grid). Each extra sample asks only whether it meets the nearer stem and takes
  // the colour of the pixel on that side: the side's position is exact, its colour borrowed from
  // one pixel away, at a fraction of a full trace.
  auto is_stem = [](int id) { return id >= kObjTree && id < kObjShrub; };
  // Marks: which neighbour lies across the edge; kFull where a full trace per sample is needed
  // (an edge within one stem, or edges on both sides of a pixel).
  constexpr uchar kRight = 1, kLeft = 2, kFull = 4;
  cv::Mat marks(h, w, CV_8U, cv::Scalar(0));
  // Whether pixel p is the nearer stem of the pair (p, q).
  auto is_front = [&](const int* id, const float* dep, int p, int q) {
    return is_stem(id[p]) && (!is_stem(id[q]) || dep[p] <= dep[q]);
  };
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v) {
    const int* id = ids.ptr<int>(v);
    const float* dep = out.depth_m.ptr<float>(v);
    uchar* mark = marks.ptr<uchar>(v);
    const Eigen::Matrix3d& rot_v = row_rotation(v);
    for (int u = 0; u + 1 < w; ++u) {
      // Only stem sides need sub-pixel accuracy: a diameter is read across a stem. Leaves,
      // ground and sky edges, and foliage in front of a stem, do not.
      const int a = id[u], b = id[u + 1];
      if (!(is_stem(a) || is_stem(b)) || a == kObjCanopy || b == kObjCanopy) continue;
      if (a == b && std::abs(dep[u + 1] - dep[u]) <= 0.04f * std::min(dep[u], dep[u + 1])) {
        continue;
      }
      const Eigen::Vector3d rc =
          cam.CamRayFromImage({u + 0.5, static_cast<double>(v)}).normalized();
      if (a == b) {
        const Sample mid = Trace(row_origin(v), rot_v * rc, columns[u], row_context(v));
        const float mid_depth = mid.t * static_cast<float>(rc.z());
        const bool like_a =
            mid.object == a && std::abs(mid_depth - dep[u]) <= 0.04f * std::min(mid_depth, dep[u]);
        mark[like_a ? u + 1 : u] |= kFull;
        continue;
      }
      const bool a_front = is_front(id, dep, u, u + 1);
      const int front = a_front ? a : b;
      const bool hit = hits_tree(front - kObjTree, rot_v * rc, v);
      if (hit == a_front) {
        mark[u + 1] |= kLeft;
      } else {
        mark[u] |= kRight;
      }
    }
  }
  static const double kOffsets[16][2] = {
      {-0.125, -0.375}, {0.375, -0.125}, {0.125, 0.375}, {-0.375, 0.125},
      {-0.3, -0.1},     {0.1, -0.3},     {0.3, 0.1},     {-0.1, 0.3},
      {-0.45, -0.45},   {0.45, -0.45},   {0.45, 0.45},   {-0.45, 0.45},
      {0.0, -0.45},     {0.45, 0.0},     {0.0, 0.45},    {-0.45, 0.0}};
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v) {
    const uchar* mark = marks.ptr<uchar>(v);
    const int* id = ids.ptr<int>(v);
    const float* dep = out.depth_m.ptr<float>(v);
    auto* rad = out.radiance.ptr<cv::Vec3f>(v);
    const std::vector<cv::Vec3f> centre(rad, rad + w);  // colours before this pass
    const Eigen::Matrix3d& rot_v = row_rotation(v);
    for (int u = 0; u < w; ++u) {
      if (!mark[u]) continue;
      const bool full = (mark[u] & kFull) || mark[u] == (kLeft | kRight);
      const int other = mark[u] == kRight ? u + 1 : u - 1;
      const bool u_front = !full && is_front(id, dep, u, other);
      const int tree = full ? -1 : id[u_front ? u : other] - kObjTree;
      cv::Vec3f sum = centre[u];
      for (int k = 0; k < options_.edge_samples; ++k) {
        const Eigen::Vector3d rc =
            cam.CamRayFromImage({u + kOffsets[k][0], v + kOffsets[k][1]}).normalized();
        if (full) {
          const Sample s = Trace(row_origin(v), rot_v * rc, columns[u], row_context(v));
          sum += cv::Vec3f(s.rgb.x(), s.rgb.y(), s.rgb.z());
        } else {
          const bool hit = hits_tree(tree, rot_v * rc, v);
          sum += centre[hit == u_front ? u : other];
        }
      }
      rad[u] = sum / static_cast<float>(options_.edge_samples + 1);
    }
  }
  return out;
}

}  // namespace stemmap::sim
