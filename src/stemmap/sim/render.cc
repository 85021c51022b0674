#include "stemmap/sim/render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "stemmap/core/error.h"
#include "stemmap/core/fast_math.h"
#include "stemmap/core/rng.h"
#include "stemmap/core/units.h"

namespace stemmap::sim {

namespace {

constexpr double kFieldTexelM = 0.15;
constexpr double kWallTexelM = 0.05;
constexpr double kWallTopM = 30.0;

double SmoothStep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

}  // namespace

void RenderOptions::Check() const {
  if (edge_samples < 0 || edge_samples > 16) throw InputError("edge_samples must be in [0, 16]");
  if (!(shadow_texel_m > 0.005 && shadow_texel_m < 0.5)) {
    throw InputError("shadow texel must be in (0.005, 0.5) m");
  }
}

Renderer::Renderer(const Scene& scene, const PinholeCamera& camera, const RenderOptions& options)
    : scene_(scene),
      camera_(camera),
      options_(options),
      ground_noise_(scene.light.seed ^ 0x1111),
      canopy_noise_(scene.light.seed ^ 0x2222),
      wall_noise_(scene.light.seed ^ 0x3333),
      leaf_noise_(scene.light.seed ^ 0x4444) {
  camera.Check();
  options.Check();
  wall_radius_m_ = scene.scene_radius_m + 6.0;
  cam_rays_ = CamRays(camera);
  inv_sun_z_ = 1.0 / scene.light.sun_dir_world.z();
  inv_shadow_texel_ = 1.0 / options.shadow_texel_m;
  BuildShadowMap();
  BuildFieldTables(-shadow_origin_x_);  // the shadow map's square, which covers the scene
}

std::vector<Eigen::Vector3f> Renderer::CamRays(const PinholeCamera& camera) {
  std::vector<Eigen::Vector3f> rays(static_cast<size_t>(camera.width) * camera.height);
  // Made again for every frame whose intrinsics change (breathing, a stabilising crop).
#pragma omp parallel for schedule(static)
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      rays[static_cast<size_t>(v) * camera.width + u] =
          camera.CamRayFromImage({static_cast<double>(u), static_cast<double>(v)})
              .normalized()
              .cast<float>();
    }
  }
  return rays;
}

void Renderer::BuildShadowMap() {
  const Lighting& L = scene_.light;
  const Eigen::Vector3d& s = L.sun_dir_world;
  const double zc = L.canopy_base_m;
  const double reach = (zc + 3.0) * std::hypot(s.x(), s.y()) / s.z();
  const double half = wall_radius_m_ + reach;
  const double texel = options_.shadow_texel_m;
  const int n = static_cast<int>(std::ceil(2.0 * half / texel));
  shadow_origin_x_ = -half;
  shadow_origin_y_ = -half;
  shadow_depth_ = cv::Mat(n, n, CV_32F, cv::Scalar(1e9));
  const Eigen::Vector3d down = -s;
  // Each tree's shadow covers a rectangle of texels; the rows are then filled in parallel, each
  // texel keeping its nearest trunk (the same whatever the order).
  struct Rect {
    const Stem* stem;
    int i0, i1, j0, j1;
  };
  std::vector<Rect> rects;
  for (const SceneTree& tree : scene_.trees) {
    const Stem& stem = tree.stem;
    const double s_top = std::min(stem.params().height_m,
                                  (zc - stem.params().base_world.z()) / stem.axis_world().z());
    if (s_top <= 0) continue;
    double x0 = kInf, x1 = -kInf, y0 = kInf, y1 = -kInf;
    for (double sa : {-0.6, s_top}) {
      const Eigen::Vector3d a = stem.AxisPoint(sa);
      const Eigen::Vector3d q = a + s * (zc - a.z()) / s.z();
      x0 = std::min(x0, q.x());
      x1 = std::max(x1, q.x());
      y0 = std::min(y0, q.y());
      y1 = std::max(y1, q.y());
    }
    const double margin = stem.BoundRadius(-0.6) / s.z() + 2 * texel;
    rects.push_back({&stem, std::max(0, static_cast<int>((y0 - margin - shadow_origin_y_) / texel)),
                     std::min(n - 1, static_cast<int>((y1 + margin - shadow_origin_y_) / texel)),
                     std::max(0, static_cast<int>((x0 - margin - shadow_origin_x_) / texel)),
                     std::min(n - 1, static_cast<int>((x1 + margin - shadow_origin_x_) / texel))});
  }
#pragma omp parallel for schedule(dynamic, 16)
  for (int i = 0; i < n; ++i) {
    float* row = shadow_depth_.ptr<float>(i);
    for (const Rect& r : rects) {
      if (i < r.i0 || i > r.i1) continue;
      for (int j = r.j0; j <= r.j1; ++j) {
        const Eigen::Vector3d o(shadow_origin_x_ + (j + 0.5) * texel,
                                shadow_origin_y_ + (i + 0.5) * texel, zc);
        const double t = r.stem->EnvelopeEntry(o, down);
        if (t < row[j]) row[j] = static_cast<float>(t);
      }
    }
  }
}

template <typename F>
Renderer::FieldTable Renderer::FieldTable::Tabulate(double x0, double y0, double texel, int nx,
                                                    int ny, F&& f) {
  FieldTable table{x0, y0, texel, 1.0 / texel, cv::Mat(ny, nx, CV_32F)};
#pragma omp parallel for schedule(static)
  for (int i = 0; i < ny; ++i) {
    float* row = table.values.ptr<float>(i);
    for (int j = 0; j < nx; ++j) row[j] = static_cast<float>(f(x0 + j * texel, y0 + i * texel));
  }
  return table;
}

void Renderer::BuildFieldTables(double half) {
  // Fields whose finest octave spans five texels or more, so that reading them bilinearly
  // changes nothing visible.
  const int nf = static_cast<int>(std::ceil(2.0 * half / kFieldTexelM)) + 2;
  fleck_ = FieldTable::Tabulate(-half, -half, kFieldTexelM, nf, nf, [&](double x, double y) {
    return canopy_noise_.Fbm2(x / 3.0, y / 3.0, 3);
  });
  ground_patch_ = FieldTable::Tabulate(-half, -half, kFieldTexelM, nf, nf, [&](double x, double y) {
    return ground_noise_.Fbm2(x / 3.0, y / 3.0, 3);
  });
  canopy_tint_ = FieldTable::Tabulate(-half, -half, kFieldTexelM, nf, nf, [&](double x, double y) {
    return canopy_noise_.Noise3(x, y, 3.3);
  });
  const double u0 = -std::numbers::pi * wall_radius_m_ - kWallTexelM;
  const int nu =
      static_cast<int>(std::ceil(2.0 * std::numbers::pi * wall_radius_m_ / kWallTexelM)) + 4;
  wall_crown_line_ = FieldTable::Tabulate(u0, 0.0, kWallTexelM, nu, 2, [&](double u, double) {
    return wall_noise_.Fbm2(u / 8.0, 0.3, 3);
  });
  const int nz = static_cast<int>(std::ceil((kWallTopM + 2.0) / kWallTexelM)) + 2;
  wall_opening_ = FieldTable::Tabulate(u0, -2.0, kWallTexelM, nu, nz, [&](double u, double z) {
    return wall_noise_.Fbm2(u / 5.0, z / 3.0, 3);
  });
}

double Renderer::SunVisibility(const Eigen::Vector3d& p) const {
  const Lighting& L = scene_.light;
  const Eigen::Vector3d& s = L.sun_dir_world;
  const double zc = L.canopy_base_m;
  const double k = (zc - p.z()) * inv_sun_z_;
  const Eigen::Vector3d q = p + s * k;
  // Sun flecks: light passes where the crowns open (same pattern for every point along a ray).
  double c;
  if (!fleck_.Read(q.x(), q.y(), &c)) c = canopy_noise_.Fbm2(q.x() / 3.0, q.y() / 3.0, 3);
  const double th = (L.canopy_cover - 0.5) * 0.7;
  double vis = SmoothStep(th - 0.05, th + 0.08, c);
  if (k <= 0 || vis <= 0) return std::max(vis, 0.0);
  // Trunk shadows from the shadow map, bilinear percentage-closer filtering.
  const double fx = (q.x() - shadow_origin_x_) * inv_shadow_texel_ - 0.5;
  const double fy = (q.y() - shadow_origin_y_) * inv_shadow_texel_ - 0.5;
  const int j = static_cast<int>(std::floor(fx)), i = static_cast<int>(std::floor(fy));
  if (i < 0 || j < 0 || i + 1 >= shadow_depth_.rows || j + 1 >= shadow_depth_.cols) return vis;
  const double wx = fx - j, wy = fy - i;
  const double bias = 0.03;
  auto lit = [&](int ii, int jj) {
    return k <= shadow_depth_.at<float>(ii, jj) + bias ? 1.0 : 0.0;
  };
  const double l = (1 - wy) * ((1 - wx) * lit(i, j) + wx * lit(i, j + 1)) +
                   wy * ((1 - wx) * lit(i + 1, j) + wx * lit(i + 1, j + 1));
  return vis * l;
}

Eigen::Vector3f Renderer::ShadeSurface(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                                       const Eigen::Vector3f& albedo, double occlusion) const {
  const Lighting& L = scene_.light;
  const double cos_sun = n.dot(L.sun_dir_world);
  const double direct = cos_sun > 0 ? cos_sun * SunVisibility(p) : 0.0;
  const double sky = (0.55 + 0.45 * n.z()) * occlusion;
  // Light bounced off the forest floor reaches downward- and sideways-facing surfaces.
  const Eigen::Vector3f bounce(0.05f, 0.06f, 0.03f);
  const Eigen::Vector3f e = L.sun_rgb * static_cast<float>(direct) +
                            L.sky_rgb * static_cast<float>(sky) +
                            bounce * static_cast<float>(0.5 - 0.5 * n.z());
  return albedo.cwiseProduct(e);
}

Eigen::Vector3f Renderer::Sky(const Eigen::Vector3d& d) const {
  const double e = std::max(d.z(), 0.0);
  const Eigen::Vector3f horizon(2.0f, 2.1f, 2.2f), zenith(1.1f, 1.35f, 1.9f);
  const float w = static_cast<float>(std::sqrt(e));
  Eigen::Vector3f c = horizon * (1 - w) + zenith * w;
  const double cs = std::max(0.0, d.dot(scene_.light.sun_dir_world));
  c += scene_.light.sun_rgb * static_cast<float>(0.5 * std::pow(cs, 8) + 6.0 * std::pow(cs, 400));
  return c;
}

Eigen::Vector3f Renderer::Wall(const Eigen::Vector3d& p, const Eigen::Vector3d& d) const {
  // The forest beyond the modelled trees: dark distant crowns and trunks, a few bright openings.
  const double phi = FastAtan2(p.y(), p.x());
  const double z = p.z() - scene_.ground.Height(p.x(), p.y());
  const double u = phi * wall_radius_m_;  // metres along the wall
  const Eigen::Vector3f shade = scene_.light.sky_rgb;
  double crown_noise, opening;
  if (!wall_crown_line_.Read(u, 0.0, &crown_noise)) crown_noise = wall_noise_.Fbm2(u / 8.0, 0.3, 3);
  if (!wall_opening_.Read(u, z, &opening)) opening = wall_noise_.Fbm2(u / 5.0, z / 3.0, 3);
  const double crown_line = 4.0 + 3.0 * crown_noise;
  if (z > crown_line) {
    if (opening > 0.32 - 0.02 * (z - crown_line)) return Sky(d);
    return Eigen::Vector3f(0.04f, 0.07f, 0.03f).cwiseProduct(shade) * 1.4f;
  }
  if (z < 0.3 + 0.3 * wall_noise_.Noise2(u / 2.0, 5.0)) {
    return Eigen::Vector3f(0.12f, 0.17f, 0.07f).cwiseProduct(shade);
  }
  const double trunk = wall_noise_.Noise2(u / 0.3, 9.7);
  if (trunk > 0.45) return Eigen::Vector3f(0.25f, 0.21f, 0.18f).cwiseProduct(shade) * 0.8f;
  if (opening > 0.15) {
    // A sunlit clearing far away.
    const double bright = 0.8 + 0.4 * wall_noise_.Noise2(u / 1.5, z / 1.5);
    return Eigen::Vector3f(0.55f, 0.65f, 0.35f) * static_cast<float>(bright * 1.6);
  }
  return Eigen::Vector3f(0.06f, 0.09f, 0.04f).cwiseProduct(shade) * 1.5f;
}

Eigen::Vector3f Renderer::GroundAlbedo(double x, double y) const {
  const ValueNoise& nz = ground_noise_;
  const bool natural = scene_.kind == StandKind::kNatural;
  double patch;
  if (!ground_patch_.Read(x, y, &patch)) patch = nz.Fbm2(x / 3.0, y / 3.0, 3);
  const Eigen::Vector3f litter =
      natural ? Eigen::Vector3f(0.20f, 0.16f, 0.10f) : Eigen::Vector3f(0.24f, 0.18f, 0.11f);
  const Eigen::Vector3f green(0.11f, 0.19f, 0.06f);
  const double g = SmoothStep(natural ? -0.2 : 0.05, natural ? 0.25 : 0.45, patch);
  Eigen::Vector3f a = litter * static_cast<float>(1 - g) + green * static_cast<float>(g);
  const double d1 = nz.Fbm2(x * 8.0, y * 8.0, 3);
  const double d2 = nz.Noise2(x * 40.0, y * 40.0);
  const double needles = nz.Noise2(x * 90.0 + 3.0 * d1, y * 25.0);
  a *= static_cast<float>(std::max(0.2, 1.0 + 0.35 * d1 + 0.2 * d2 + 0.15 * needles));
  if (nz.Noise2(x * 6.0 + 40.0, y * 6.0) > 0.72) a *= 0.75f;  // twigs, holes, shade under litter
  return a;
}

double Renderer::IntersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                 double t_max) const {
  const Ground& g = scene_.ground;
  const double lip = g.LipschitzBound();
  const double dxy = std::sqrt(d.x() * d.x() + d.y() * d.y());  // not hypot: hot, and no overflow
  if (d.z() > lip * dxy) return kInf;                           // climbs faster than any slope
  // Skip to where the ray enters the slab of ±bump around the ground plane.
  double t = 0.0;
  const Eigen::Vector2d& pg = g.plane_gradient();
  const double above = o.z() - g.PlaneHeight(o.x(), o.y()) - g.BumpBound();
  const double closing = -(d.z() - pg.dot(d.head<2>()));  // rate the gap to the slab top shrinks
  // The height above the ground falls at `closing` per metre of ray from the plane alone, and at
  // most the bumps' slope more: the safe step, exact for the plane (tighter than one bound for
  // both where the ray runs along or down the slope).
  const double inv_rate = 1.0 / (std::max(closing, 0.0) + g.BumpLipschitzBound() * dxy);
  if (above > 0) {
    if (closing <= 0) return kInf;
    t = above / closing;
    if (t >= t_max) return kInf;
  }
  Eigen::Vector3d p0 = o + t * d;
  double h = p0.z() - g.Height(p0.x(), p0.y());
  if (h <= 0) return t > 0 ? t : kInf;
  // Over-relaxed sphere tracing: twice the safe step, and a crossing found between two samples is
  // refined by regula falsi. The ground is smooth at the step sizes near it, so a skipped sliver
  // of a crest is the only cost, and grazing rays need half the steps.
  constexpr double kRelax = 2.0;
  for (int it = 0; it < 96 && t < t_max; ++it) {
    if (h < 1e-4 * (1.0 + t)) return t;
    const double t_next = t + std::max(kRelax * h * inv_rate, 1e-4);
    const Eigen::Vector3d p = o + t_next * d;
    const double h_next = p.z() - g.Height(p.x(), p.y());
    if (h_next < 0) {
      // Illinois variant: halve the weight of an end that stays put twice.
      double lo = t, hi = t_next, h_lo = h, h_hi = h_next;
      int side = 0;
      for (int b = 0; b < 8 && hi - lo > 1e-5 * (1.0 + lo); ++b) {
        const double mid = lo + (hi - lo) * h_lo / (h_lo - h_hi);
        const Eigen::Vector3d pm = o + mid * d;
        const double h_mid = pm.z() - g.Height(pm.x(), pm.y());
        // Done when the gap left, over the rate the ray closes on the ground, is under 1e-4 of
        // the range: the hit then moves the texture by far less than a pixel's footprint.
        if (std::abs(h_mid) * (hi - lo) < 1e-4 * (1.0 + mid) * (h_lo - h_hi)) return mid;
        if (h_mid < 0) {
          hi = mid;
          h_hi = h_mid;
          if (side == -1) h_lo *= 0.5;
          side = -1;
        } else {
          lo = mid;
          h_lo = h_mid;
          if (side == 1) h_hi *= 0.5;
          side = 1;
        }
      }
      return hi;
    }
    t = t_next;
    h = h_next;
  }
  return kInf;
}

Renderer::ShrubView Renderer::ViewShrub(int k, const Eigen::Vector3d& o,
                                        const Eigen::Vector3d& offset_m) const {
  const Shrub& sh = scene_.shrubs[k];
  ShrubView view;
  view.inv_radii = sh.radii_m.cwiseInverse();
  view.o_scaled = (o - sh.centre - offset_m).cwiseProduct(view.inv_radii);
  view.c = view.o_scaled.squaredNorm() - 1.0;
  // Each shrub reads its own region of the shared noise, and carries its leaves when it sways.
  view.leaf_offset =
      Eigen::Vector3d(HashToUnit(sh.seed) * 300.0, HashToUnit(Mix64(sh.seed)) * 300.0, 0.0) -
      offset_m;
  return view;
}

bool Renderer::IntersectShrub(int k, const ShrubView& view, const Eigen::Vector3d& o,
                              const Eigen::Vector3d& d, double t_max, double* t_hit,
                              Eigen::Vector3d* n, Eigen::Vector3f* albedo) const {
  const Shrub& sh = scene_.shrubs[k];
  // The ellipsoid scaled to the unit sphere: the ray's point at t is os + t ds there.
  const Eigen::Vector3d& os = view.o_scaled;
  const Eigen::Vector3d ds = d.cwiseProduct(view.inv_radii);
  const double a = ds.squaredNorm(), b = os.dot(ds), c = view.c;
  const double disc = b * b - a * c;
  if (disc <= 0) return false;
  const double sq = std::sqrt(disc);
  double t0 = std::max((-b - sq) / a, 1e-3);
  const double t1 = std::min((-b + sq) / a, t_max);
  if (t0 >= t1) return false;
  const ValueNoise& leaf = leaf_noise_;
  const Eigen::Vector3d& off = view.leaf_offset;
  const double th = 1.05 - 0.6 * sh.density;
  const double step = 0.045;
  // Lobed outline: the leaf threshold varies across the shrub at the scale of branches.
  const Eigen::Vector3d pe = o + t0 * d + off;
  const double lobes = 0.5 * leaf.Noise3(pe.x() * 2.5 + 50.0, pe.y() * 2.5, pe.z() * 2.5);
  // The leaf noise never exceeds its largest lattice value, so where even that would leave v at
  // or under the threshold the noise need not be read (a few 1e-9 spare for rounding).
  const double centre_needed = th + 0.2 - lobes - leaf.MaxValue() + 1e-9;
  const double q_min2 = std::max(0.0, c + 1.0 - b * b / a);  // closest approach, scaled frame
  if (0.6 * (1.0 - std::sqrt(q_min2)) <= centre_needed) return false;
  for (double t = t0; t < t1; t += step) {
    const Eigen::Vector3d pw = o + t * d;
    const Eigen::Vector3d q = os + t * ds;
    const double centre = 0.6 * (1.0 - q.norm());
    if (centre <= centre_needed) continue;
    const Eigen::Vector3d p = pw + off;
    // Denser towards the centre, with leaf-sized holes.
    const double v = leaf.Noise3(p.x() * 18.0, p.y() * 18.0, p.z() * 18.0) + centre + lobes - 0.2;
    if (v > th) {
      *t_hit = t;
      const double h = 0.02;
      const double v0 = leaf.Noise3(p.x() * 12.0, p.y() * 12.0, p.z() * 12.0);
      Eigen::Vector3d gdir(leaf.Noise3((p.x() + h) * 12.0, p.y() * 12.0, p.z() * 12.0) - v0,
                           leaf.Noise3(p.x() * 12.0, (p.y() + h) * 12.0, p.z() * 12.0) - v0,
                           leaf.Noise3(p.x() * 12.0, p.y() * 12.0, (p.z() + h) * 12.0) - v0);
      *n = (q.normalized() * 0.6 - gdir.normalized() * 0.4 - d * 0.3).normalized();
      const double tint =
          0.75 + 0.5 * (0.5 + 0.5 * leaf.Noise3(p.x() * 23.0, p.y() * 23.0, p.z() * 23.0));
      *albedo = Eigen::Vector3f(0.09f, 0.20f, 0.05f) * static_cast<float>(tint);
      return true;
    }
  }
  return false;
}

}  // namespace stemmap::sim
