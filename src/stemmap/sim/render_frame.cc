// Per-frame setup: the objects a frame may show, each image column's share of them, and the
// objects' views of a ray origin; the autofocus's metering.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "stemmap/sim/render.h"

namespace stemmap::sim {

namespace {

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

Renderer::FrameObjects Renderer::FindObjects(const Eigen::Vector3d& o, const Eigen::Matrix3d& rot,
                                             const PinholeCamera& cam, double reach_m,
                                             double turn_rad, const SceneSway& sway) const {
  const int w = cam.width, h = cam.height;
  double hfov = std::atan(0.5 * w / cam.fx), vfov = std::atan(0.5 * h / cam.fy);
  if (cam.HasDistortion() || cam.cx != camera_.cx || cam.cy != camera_.cy) {
    // A barrel lens sees farther than its pinhole part, and a shifted crop farther to one side:
    // the border pixels' own rays say how far.
    for (const double u : {-0.5, 0.5 * (w - 1), w - 0.5}) {
      for (const double v : {-0.5, 0.5 * (h - 1), h - 0.5}) {
        const Eigen::Vector3d r = cam.CamRayFromImage({u, v});
        hfov = std::max(hfov, std::atan(std::abs(r.x())));
        vfov = std::max(vfov, std::atan(std::abs(r.y())));
      }
    }
  }

  // Objects that may be seen this frame, with their azimuth extent from the camera. An origin
  // that moves by up to reach_m over the frame (a rolling shutter) widens every object by as much.
  FrameObjects frame;
  std::vector<Candidate>& objects = frame.objects;
  const Eigen::Vector2d c_xy = o.head<2>();
  const double view_az =
      std::atan2((rot * Eigen::Vector3d::UnitZ()).y(), (rot * Eigen::Vector3d::UnitZ()).x());
  const auto tilted = [&](int i) {
    return !sway.tree_tilt.empty() && sway.tree_tilt[i].vec().squaredNorm() > 0.0;
  };
  for (int i = 0; i < static_cast<int>(scene_.trees.size()); ++i) {
    const Stem& stem = scene_.trees[i].stem;
    const Eigen::Vector2d a = stem.AxisPoint(-0.6).head<2>() - c_xy;
    const double dist = a.norm();
    const double z_top = o.z() + dist * std::tan(vfov + 0.05) + 2.0;
    const double s_top = std::min(stem.params().height_m,
                                  (z_top - stem.params().base_world.z()) / stem.axis_world().z());
    const Eigen::Vector2d b = stem.AxisPoint(std::max(s_top, 0.0)).head<2>() - c_xy;
    double rb = stem.BoundRadius(-0.6) + reach_m;
    // A tilted stem moves by at most the turn's angle times its length.
    if (tilted(i)) rb += Eigen::AngleAxisd(sway.tree_tilt[i]).angle() * stem.params().height_m;
    const double dmin = SegmentDistance(a, b);
    if (dmin <= rb) {
      objects.push_back({i, 0.0, view_az, std::numbers::pi});
      continue;
    }
    const double az_a = std::atan2(a.y(), a.x()), az_b = std::atan2(b.y(), b.x());
    const double centre = az_a + 0.5 * WrapPi(az_b - az_a);
    const double half = 0.5 * std::abs(WrapPi(az_b - az_a)) + std::asin(std::min(1.0, rb / dmin));
    if (std::abs(WrapPi(centre - view_az)) > half + hfov + 0.3 + turn_rad) continue;
    objects.push_back({i, dmin - rb, centre, half});
  }
  const auto shrub_offset = [&](int k) {
    return sway.shrub_offset_m.empty() ? Eigen::Vector3d::Zero().eval() : sway.shrub_offset_m[k];
  };
  for (int k = 0; k < static_cast<int>(scene_.shrubs.size()); ++k) {
    const Shrub& sh = scene_.shrubs[k];
    const Eigen::Vector2d a = (sh.centre + shrub_offset(k)).head<2>() - c_xy;
    const double r = sh.radii_m.maxCoeff() + reach_m;
    const double dist = a.norm();
    if (dist <= r) {
      objects.push_back({-(k + 1), 0.0, view_az, std::numbers::pi});
      continue;
    }
    const double centre = std::atan2(a.y(), a.x());
    const double half = std::asin(std::min(1.0, r / dist));
    if (std::abs(WrapPi(centre - view_az)) > half + hfov + 0.3 + turn_rad) continue;
    objects.push_back({-(k + 1), dist - r, centre, half});
  }
  std::sort(objects.begin(), objects.end(), [](const Candidate& x, const Candidate& y) {
    return x.min_dist_xy_m < y.min_dist_xy_m;
  });
  // Each object's view of a ray origin is computed once per origin, into a table by
  // Candidate::view.
  frame.view_of_tree.assign(scene_.trees.size(), -1);
  for (Candidate& c : objects) {
    if (c.index < 0) {
      c.view = static_cast<int>(frame.shrub_of_view.size());
      frame.shrub_of_view.push_back(-c.index - 1);
      frame.shrub_offset_m.push_back(shrub_offset(-c.index - 1));
      continue;
    }
    c.view = static_cast<int>(frame.tree_of_view.size());
    frame.tree_of_view.push_back(c.index);
    frame.view_of_tree[c.index] = c.view;
    frame.rest_from_world.push_back(
        tilted(c.index) ? Eigen::Matrix3d(sway.tree_tilt[c.index].toRotationMatrix().transpose())
                        : Eigen::Matrix3d::Identity().eval());
  }
  for (Candidate& c : objects) {
    if (c.index >= 0 && tilted(c.index)) c.rest_from_world = &frame.rest_from_world[c.view];
  }
  frame.crown_offset_m = sway.crown_offset_m;
  return frame;
}

Renderer::TraceContext Renderer::ViewFrom(const FrameObjects& frame, const Eigen::Vector3d& o,
                                          Stem::RayOrigin* tree_views,
                                          ShrubView* shrub_views) const {
  for (size_t v = 0; v < frame.tree_of_view.size(); ++v) {
    const Stem& stem = scene_.trees[frame.tree_of_view[v]].stem;
    const Eigen::Matrix3d& rest = frame.rest_from_world[v];
    if (rest.isIdentity(0.0)) {
      tree_views[v] = stem.PrepareOrigin(o);
    } else {
      const Eigen::Vector3d& base = stem.params().base_world;
      tree_views[v] = stem.PrepareOrigin(rest * (o - base) + base);
    }
  }
  for (size_t v = 0; v < frame.shrub_of_view.size(); ++v) {
    shrub_views[v] = ViewShrub(frame.shrub_of_view[v], o, frame.shrub_offset_m[v]);
  }
  return {tree_views, shrub_views, frame.crown_offset_m};
}

RenderBuffers Renderer::Render(const Rigid3d& world_from_cam) const {
  FrameSetup frame;
  frame.world_from_cam = world_from_cam;
  return Render(frame);
}

double Renderer::CentreDepth(const FrameSetup& frame, double window, int samples) const {
  const PinholeCamera& cam = frame.camera ? *frame.camera : camera_;
  const Eigen::Matrix3d rot = frame.world_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d o = frame.world_from_cam.translation;
  const FrameObjects objects = FindObjects(o, rot, cam, 0.0, 0.0, frame.sway);
  std::vector<Stem::RayOrigin> tree_views(objects.tree_of_view.size());
  std::vector<ShrubView> shrub_views(objects.shrub_of_view.size());
  const TraceContext context = ViewFrom(objects, o, tree_views.data(), shrub_views.data());
  std::vector<double> depths;
  const int n = std::max(samples, 1);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double fu = n > 1 ? static_cast<double>(j) / (n - 1) - 0.5 : 0.0;
      const double fv = n > 1 ? static_cast<double>(i) / (n - 1) - 0.5 : 0.0;
      const Eigen::Vector3d rc =
          cam.CamRayFromImage({0.5 * (cam.width - 1) + fu * window * cam.width,
                               0.5 * (cam.height - 1) + fv * window * cam.height})
              .normalized();
      const Eigen::Vector3d d = rot * rc;
      const std::vector<Candidate> candidates =
          ColumnCandidates(o, objects.objects, std::atan2(d.y(), d.x()), 1.0 / cam.fx);
      depths.push_back(Trace(o, d, candidates, context).t * rc.z());
    }
  }
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  return depths[depths.size() / 2];
}

std::vector<std::vector<Renderer::Candidate>> Renderer::ColumnLists(
    const FrameObjects& objects, const Eigen::Vector3d& o, const Eigen::Matrix3d& rot,
    const std::vector<Eigen::Vector3f>& cam_rays, const PinholeCamera& cam, double turn_rad) const {
  // Candidate lists per column; a column's azimuth range spans its top and bottom rays (and, with
  // a rolling shutter, what the rows' turns add to their azimuths).
  const int w = cam.width, h = cam.height;
  std::vector<std::vector<Candidate>> columns(w);
  for (int u = 0; u < w; ++u) {
    double az[3];
    double max_dz = 0.0;
    int k = 0;
    for (int v : {0, h / 2, h - 1}) {
      const Eigen::Vector3d d = rot * cam_rays[static_cast<size_t>(v) * w + u].cast<double>();
      az[k++] = std::atan2(d.y(), d.x());
      max_dz = std::max(max_dz, std::abs(d.z()));
    }
    const double lo = std::min({0.0, WrapPi(az[0] - az[1]), WrapPi(az[2] - az[1])});
    const double hi = std::max({0.0, WrapPi(az[0] - az[1]), WrapPi(az[2] - az[1])});
    const double centre = az[1] + 0.5 * (lo + hi);
    double half = 0.5 * (hi - lo) + 1.0 / cam.fx;  // ± half a pixel and a margin
    if (turn_rad > 0.0) {
      half += turn_rad / std::max(std::sqrt(std::max(0.0, 1.0 - max_dz * max_dz)), 0.1);
    }
    columns[u] = ColumnCandidates(o, objects.objects, centre, half);
  }
  return columns;
}

}  // namespace stemmap::sim
