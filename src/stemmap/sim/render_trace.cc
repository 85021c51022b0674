// Per-frame ray casting: candidate culling per image column, tracing, and edge antialiasing.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "stemmap/core/fast_math.h"
#include "stemmap/core/units.h"
#include "stemmap/sim/render.h"

namespace stemmap::sim {

namespace {

constexpr int kObjSky = 0, kObjGround = 1, kObjWall = 2, kObjCanopy = 3, kObjTree = 100,
              kObjShrub = 100000;

double WrapPi(double a) {
  a = std::fmod(a + std::numbers::pi, 2.0 * std::numbers::pi);
  if (a < 0) a += 2.0 * std::numbers::pi;
  return a - std::numbers::pi;
}

// Closest point of segment ab to the origin, in the plane.
double SegmentDistance(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp(-a.dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab).norm();
}

}  // namespace

std::vector<Renderer::Candidate> Renderer::ColumnCandidates(const Eigen::Vector3d&,
                                                            const std::vector<Candidate>& objects,
                                                            double col_az, double col_half) const {
  std::vector<Candidate> out;
  for (const Candidate& c : objects) {
    if (std::abs(WrapPi(c.centre_az - col_az)) <= c.half_width + col_half) out.push_back(c);
  }
  return out;
}

Renderer::Sample Renderer::Trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                 const std::vector<Candidate>& candidates) const {
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
  for (const Candidate& c : candidates) {
    const double t_limit = std::min(t_best, t_ground_max);
    if (c.min_dist_xy_m > t_limit * dxy + 1e-6) break;
    if (c.index >= 0) {
      const Stem& stem = scene_.trees[c.index].stem;
      const double tol = 0.25 / camera_.fx;
      const auto point = c.origin ? stem.FirstSurfacePoint(*c.origin, d, 1e-4, t_limit, tol)
                                  : stem.FirstSurfacePoint(o, d, 1e-4, t_limit, tol);
      if (point) {
        t_best = point->t;
        object = kObjTree + c.index;
        stem_point = *point;
      }
    } else {
      double t;
      Eigen::Vector3d n;
      Eigen::Vector3f a;
      const int k = -c.index - 1;
      if (IntersectShrub(k, c.shrub ? *c.shrub : ViewShrub(k, o), o, d, t_limit, &t, &n, &a)) {
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
    normal = hit.normal_world;
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
        const Eigen::Vector3d p = o + t * d;
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

RenderBuffers Renderer::Render(const Rigid3d& world_from_cam) const {
  const int w = camera_.width, h = camera_.height;
  const Eigen::Matrix3d rot = world_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d o = world_from_cam.translation;
  const double hfov = std::atan(0.5 * w / camera_.fx), vfov = std::atan(0.5 * h / camera_.fy);

  // Objects that may be seen this frame, with their azimuth extent from the camera.
  std::vector<Candidate> objects;
  const Eigen::Vector2d c_xy = o.head<2>();
  const double view_az =
      std::atan2((rot * Eigen::Vector3d::UnitZ()).y(), (rot * Eigen::Vector3d::UnitZ()).x());
  for (int i = 0; i < static_cast<int>(scene_.trees.size()); ++i) {
    const Stem& stem = scene_.trees[i].stem;
    const Eigen::Vector2d a = stem.AxisPoint(-0.6).head<2>() - c_xy;
    const double dist = a.norm();
    const double z_top = o.z() + dist * std::tan(vfov + 0.05) + 2.0;
    const double s_top = std::min(stem.params().height_m,
                                  (z_top - stem.params().base_world.z()) / stem.axis_world().z());
    const Eigen::Vector2d b = stem.AxisPoint(std::max(s_top, 0.0)).head<2>() - c_xy;
    const double rb = stem.BoundRadius(-0.6);
    const double dmin = SegmentDistance(a, b);
    if (dmin <= rb) {
      objects.push_back({i, 0.0, view_az, std::numbers::pi});
      continue;
    }
    const double az_a = std::atan2(a.y(), a.x()), az_b = std::atan2(b.y(), b.x());
    const double centre = az_a + 0.5 * WrapPi(az_b - az_a);
    const double half = 0.5 * std::abs(WrapPi(az_b - az_a)) + std::asin(std::min(1.0, rb / dmin));
    if (std::abs(WrapPi(centre - view_az)) > half + hfov + 0.3) continue;
    objects.push_back({i, dmin - rb, centre, half});
  }
  for (int k = 0; k < static_cast<int>(scene_.shrubs.size()); ++k) {
    const Shrub& sh = scene_.shrubs[k];
    const Eigen::Vector2d a = sh.centre.head<2>() - c_xy;
    const double r = sh.radii_m.maxCoeff();
    const double dist = a.norm();
    if (dist <= r) {
      objects.push_back({-(k + 1), 0.0, view_az, std::numbers::pi});
      continue;
    }
    const double centre = std::atan2(a.y(), a.x());
    const double half = std::asin(std::min(1.0, r / dist));
    if (std::abs(WrapPi(centre - view_az)) > half + hfov + 0.3) continue;
    objects.push_back({-(k + 1), dist - r, centre, half});
  }
  std::sort(objects.begin(), objects.end(), [](const Candidate& x, const Candidate& y) {
    return x.min_dist_xy_m < y.min_dist_xy_m;
  });
  // Every ray of the frame starts at o: each tree's view of it is computed once.
  std::vector<Stem::RayOrigin> origins;
  origins.reserve(objects.size());
  std::vector<const Stem::RayOrigin*> tree_origin(scene_.trees.size(), nullptr);
  std::vector<ShrubView> shrub_views;
  shrub_views.reserve(objects.size());
  for (Candidate& c : objects) {
    if (c.index < 0) {
      shrub_views.push_back(ViewShrub(-c.index - 1, o));
      c.shrub = &shrub_views.back();
      continue;
    }
    origins.push_back(scene_.trees[c.index].stem.PrepareOrigin(o));
    c.origin = tree_origin[c.index] = &origins.back();
  }
  // Whether a ray of this frame meets tree i.
  auto hits_tree = [&](int i, const Eigen::Vector3d& d) {
    const Stem& stem = scene_.trees[i].stem;
    const double tol = 0.25 / camera_.fx;
    return (tree_origin[i] ? stem.FirstSurfacePoint(*tree_origin[i], d, 1e-4, kInf, tol)
                           : stem.FirstSurfacePoint(o, d, 1e-4, kInf, tol))
        .has_value();
  };

  // Candidate lists per column; a column's azimuth range spans its top and bottom rays.
  std::vector<std::vector<Candidate>> columns(w);
  for (int u = 0; u < w; ++u) {
    double az[3];
    int k = 0;
    for (int v : {0, h / 2, h - 1}) {
      const Eigen::Vector3d d = rot * cam_rays_[static_cast<size_t>(v) * w + u].cast<double>();
      az[k++] = std::atan2(d.y(), d.x());
    }
    const double lo = std::min({0.0, WrapPi(az[0] - az[1]), WrapPi(az[2] - az[1])});
    const double hi = std::max({0.0, WrapPi(az[0] - az[1]), WrapPi(az[2] - az[1])});
    const double centre = az[1] + 0.5 * (lo + hi);
    const double half = 0.5 * (hi - lo) + 1.0 / camera_.fx;  // ± half a pixel and a margin
    columns[u] = ColumnCandidates(o, objects, centre, half);
  }

  RenderBuffers out;
  out.radiance = cv::Mat(h, w, CV_32FC3);
  out.depth_m = cv::Mat(h, w, CV_32F);
  cv::Mat ids(h, w, CV_32S);
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v) {
    auto* rad = out.radiance.ptr<cv::Vec3f>(v);
    auto* dep = out.depth_m.ptr<float>(v);
    auto* id = ids.ptr<int>(v);
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3f& rc = cam_rays_[static_cast<size_t>(v) * w + u];
      const Sample s = Trace(o, rot * rc.cast<double>(), columns[u]);
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
    for (int u = 0; u + 1 < w; ++u) {
      // Only stem sides need sub-pixel accuracy: a diameter is read across a stem. Leaves,
      // ground and sky edges, and foliage in front of a stem, do not.
      const int a = id[u], b = id[u + 1];
      if (!(is_stem(a) || is_stem(b)) || a == kObjCanopy || b == kObjCanopy) continue;
      if (a == b && std::abs(dep[u + 1] - dep[u]) <= 0.04f * std::min(dep[u], dep[u + 1])) {
        continue;
      }
      const Eigen::Vector3d rc =
          camera_.CamRayFromImage({u + 0.5, static_cast<double>(v)}).normalized();
      if (a == b) {
        const Sample mid = Trace(o, rot * rc, columns[u]);
        const float mid_depth = mid.t * static_cast<float>(rc.z());
        const bool like_a =
            mid.object == a && std::abs(mid_depth - dep[u]) <= 0.04f * std::min(mid_depth, dep[u]);
        mark[like_a ? u + 1 : u] |= kFull;
        continue;
      }
      const bool a_front = is_front(id, dep, u, u + 1);
      const int front = a_front ? a : b;
      const bool hit = hits_tree(front - kObjTree, rot * rc);
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
    for (int u = 0; u < w; ++u) {
      if (!mark[u]) continue;
      const bool full = (mark[u] & kFull) || mark[u] == (kLeft | kRight);
      const int other = mark[u] == kRight ? u + 1 : u - 1;
      const bool u_front = !full && is_front(id, dep, u, other);
      const int tree = full ? -1 : id[u_front ? u : other] - kObjTree;
      cv::Vec3f sum = centre[u];
      for (int k = 0; k < options_.edge_samples; ++k) {
        const Eigen::Vector3d rc =
            camera_.CamRayFromImage({u + kOffsets[k][0], v + kOffsets[k][1]}).normalized();
        if (full) {
          const Sample s = Trace(o, rot * rc, columns[u]);
          sum += cv::Vec3f(s.rgb.x(), s.rgb.y(), s.rgb.z());
        } else {
          const bool hit = hits_tree(tree, rot * rc);
          sum += centre[hit == u_front ? u : other];
        }
      }
      rad[u] = sum / static_cast<float>(options_.edge_samples + 1);
    }
  }
  return out;
}

}  // namespace stemmap::sim
