#include "stemmap/sim/stem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "stemmap/core/fast_math.h"
#include "stemmap/core/rng.h"

namespace stemmap::sim {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kBelowGroundM = 0.6;  // stems reach below the surface so slopes leave no gap
constexpr double kFurrowWidth = 0.18;  // furrow half-width as a share of one plate
constexpr double kCrackWidth = 0.04;
// Reciprocals: the bark is evaluated several times per ray, and a division costs many products.
constexpr double kInvFurrowWidth = 1.0 / kFurrowWidth;
constexpr double kInvCrackWidth = 1.0 / kCrackWidth;
constexpr double kPlateLengthM = 0.2;

// Entry and exit of a ray with the infinite cylinder x^2 + y^2 = r^2 (stem frame).
bool CylinderSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, double* t0,
                  double* t1) {
  const double a = d.x() * d.x() + d.y() * d.y();
  const double b = o.x() * d.x() + o.y() * d.y();
  const double c = o.x() * o.x() + o.y() * o.y() - r * r;
  if (a < 1e-14) {
    if (c > 0) return false;
    *t0 = -1e30;
    *t1 = 1e30;
    return true;
  }
  const double disc = b * b - a * c;
  if (disc < 0) return false;
  const double sq = std::sqrt(disc);
  *t0 = (-b - sq) / a;
  *t1 = (-b + sq) / a;
  return true;
}

}  // namespace

Stem::Stem(const StemParams& p) : p_(p), exp_neg_(&ExpNegTable::Get()), noise_(p.seed) {
  axis_world_ =
      Eigen::Vector3d(std::sin(p.lean_rad) * std::cos(p.lean_azimuth_rad),
                      std::sin(p.lean_rad) * std::sin(p.lean_azimuth_rad), std::cos(p.lean_rad));
  world_from_stem_ = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis_world_);
  stem_from_world_ = world_from_stem_.conjugate().toRotationMatrix();
  a_unit_ = 2.0 / (1.0 + p.axis_ratio);
  b_unit_ = p.axis_ratio * a_unit_;
  inv_a_unit_ = 1.0 / a_unit_;
  inv_b_unit_ = 1.0 / b_unit_;
  inv_flare_height_ = 1.0 / p.flare_height_m;
  flare_top_m_ = 16.0 * p.flare_height_m;
  cos_ell_ = std::cos(p.ellipse_azimuth_rad);
  sin_ell_ = std::sin(p.ellipse_azimuth_rad);
  n_furrows_ = static_cast<int>(
      std::clamp(std::round(kTwoPi * p.radius_bh_m / p.furrow_spacing_m), 6.0, 500.0));
  // The furrow warp steepens the relief about as much as the furrows themselves.
  const double relief_slope_per_rad =
      p.furrow_depth_m * 1.3 * (n_furrows_ + 30) / (kFurrowWidth * kTwoPi);
  const double r_min = std::max(0.01, MeanRadius(std::min(p.height_m, 4.0)));
  march_lipschitz_ = 1.3 + relief_slope_per_rad / r_min;
  // The warp moves the plate coordinate by at most 1.6 either way of [0, n_furrows_).
  for (int64_t ridge = kFirstRidge; ridge <= n_furrows_ + 2; ++ridge) {
    plates_.push_back(HashPlates(ridge));
  }
  // The mean radius shrinks upward when the stem tapers, so its largest value is at the bottom.
  envelope_bound_m_ = p.taper_m_per_m >= 0 ? MeanRadius(-kBelowGroundM) : -1.0;
}

inline double Stem::MeanRadius(double s, double* slope) const {
  double r = p_.radius_bh_m + p_.taper_m_per_m * (p_.s_bh_m - s);
  double dr_ds = -p_.taper_m_per_m;
  // The flare has vanished (< 1e-7 of the radius) well above the ground.
  if (s < flare_top_m_) {
    const double flare =
        p_.radius_bh_m * p_.flare * (*exp_neg_)(std::max(s, 0.0) * inv_flare_height_);
    r += flare;
    if (s > 0) dr_ds -= flare * inv_flare_height_;
  }
  if (slope) *slope = r > 0.01 ? dr_ds : 0.0;
  return std::max(r, 0.01);
}

double Stem::BoundRadius(double s) const {
  return a_unit_ * MeanRadius(std::max(s, -kBelowGroundM)) + 1e-4;
}

double Stem::TurnFraction(double x, double y) {
  const double u = FastAtan2(y, x) / kTwoPi;
  return u < 0 ? u + 1.0 : u;
}

double Stem::Relief(double u, double s, double* grad) const {
  // Furrows wander: a smooth, azimuth-periodic warp of the plate coordinate. `grad`, where asked,
  // follows each piece: d/du and d/ds of the relief, one-sided at the profiles' corners.
  double g_warp[2], g_depth[2];
  const double warp = 1.6 * noise_.Noise2PeriodicX(u * 5.0, 1.5 * s, 5, grad ? g_warp : nullptr);
  const double uf = u * n_furrows_ + warp;
  const double cell = uf - std::floor(uf);
  const double d_furrow = std::min(cell, 1.0 - cell);
  double relief = 0.0;
  if (grad) grad[0] = grad[1] = 0.0;
  if (d_furrow < kFurrowWidth) {
    const double depth_mod =
        0.65 + 0.35 * noise_.Noise2PeriodicX(u * 6.0, 2.5 * s, 6, grad ? g_depth : nullptr);
    const double k = 1.0 - d_furrow * kInvFurrowWidth;
    const double sqrt_k = std::sqrt(k);
    relief -= p_.furrow_depth_m * depth_mod * k * sqrt_k;
    if (grad) {
      // d(d_furrow) = ±d(uf); d(uf)/du = n + 1.6·5·∂x warp noise, d(uf)/ds = 1.6·1.5·∂y.
      const double side = cell < 0.5 ? 1.0 : -1.0;
      const double dk_du = -side * (n_furrows_ + 8.0 * g_warp[0]) * kInvFurrowWidth;
      const double dk_ds = -side * 2.4 * g_warp[1] * kInvFurrowWidth;
      grad[0] = -p_.furrow_depth_m *
                (0.35 * 6.0 * g_depth[0] * k * sqrt_k + depth_mod * 1.5 * sqrt_k * dk_du);
      grad[1] = -p_.furrow_depth_m *
                (0.35 * 2.5 * g_depth[1] * k * sqrt_k + depth_mod * 1.5 * sqrt_k * dk_ds);
    }
  }
  // Horizontal cracks split the ridges into plates, offset per ridge.
  const Plates plates = RidgePlates(static_cast<int64_t>(std::floor(uf)));
  const double plate_len = plates.length_m;
  const double v = s / plate_len + plates.offset;
  const double vc = v - std::floor(v);
  const double d_crack = std::min(vc, 1.0 - vc);
  if (d_crack < kCrackWidth) {
    const double crack = -0.3 * p_.furrow_depth_m * (1.0 - d_crack * kInvCrackWidth);
    if (crack < relief) {
      relief = crack;
      if (grad) {
        grad[0] = 0.0;
        grad[1] = 0.3 * p_.furrow_depth_m * kInvCrackWidth * (vc < 0.5 ? 1.0 : -1.0) / plate_len;
      }
    }
  }
  return relief;
}

Stem::Plates Stem::HashPlates(int64_t ridge) const {
  const auto key = static_cast<uint64_t>(ridge + 100000);
  return {kPlateLengthM * (0.6 + 1.2 * HashToUnit(HashCombine(key, p_.seed))),
          HashToUnit(HashCombine(p_.seed, key))};
}

double Stem::EllipseFactor(double c, double sn, double* slope) const {
  const double ca = c * cos_ell_ + sn * sin_ell_, sa = -c * sin_ell_ + sn * cos_ell_;
  const double a2 = a_unit_ * a_unit_, b2 = b_unit_ * b_unit_;
  const double den = b2 * ca * ca + a2 * sa * sa;
  const double e = a_unit_ * b_unit_ / std::sqrt(den);
  // d(den)/dphi = 2 ca sa (a² - b²), and E = ab den^(-1/2).
  if (slope) *slope = -e * ca * sa * (a2 - b2) / den;
  return e;
}

double Stem::SurfaceRadius(double phi, double s) const {
  double u = phi / kTwoPi;
  u -= std::floor(u);
  return EllipseFactor(std::cos(phi), std::sin(phi)) * MeanRadius(s) + Relief(u, s);
}

double Stem::Field(const Eigen::Vector3d& q, FieldParts* parts) const {
  if (parts) parts->valid = false;
  if (q.z() < -kBelowGroundM || q.z() > p_.height_m) return 1.0;
  const double rho = std::sqrt(q.x() * q.x() + q.y() * q.y());  // not hypot: hot, and no overflow
  if (rho < 1e-9) return -MeanRadius(q.z());
  const double e = EllipseFactor(q.x() / rho, q.y() / rho);
  const double phi = FastAtan2(q.y(), q.x());
  double u = phi / kTwoPi;  // as TurnFraction
  if (u < 0) u += 1.0;
  const double mean_radius = MeanRadius(q.z());
  const double relief = Relief(u, q.z());
  const double surface = e * mean_radius + relief;
  if (parts) *parts = {true, rho, u, mean_radius, relief};
  return rho - surface;
}

std::optional<StemHit> Stem::Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                       double t_min, double t_max, double tol_per_m) const {
  const std::optional<SurfacePoint> point = FirstSurfacePoint(o, d, t_min, t_max, tol_per_m);
  if (!point) return std::nullopt;
  return Shade(*point);
}

std::optional<Stem::SurfacePoint> Stem::FirstSurfacePoint(const Eigen::Vector3d& o,
                                                          const Eigen::Vector3d& d, double t_min,
                                                          double t_max, double tol_per_m) const {
  return FirstSurfacePoint(PrepareOrigin(o), d, t_min, t_max, tol_per_m);
}

Stem::RayOrigin Stem::PrepareOrigin(const Eigen::Vector3d& o_world) const {
  RayOrigin o;
  o.o_stem = stem_from_world_ * (o_world - p_.base_world);
  // Envelope (relief-free elliptic cylinder) in coordinates where it is circular of radius r(s).
  o.ox = (o.o_stem.x() * cos_ell_ + o.o_stem.y() * sin_ell_) * inv_a_unit_;
  o.oy = (-o.o_stem.x() * sin_ell_ + o.o_stem.y() * cos_ell_) * inv_b_unit_;
  return o;
}

std::optional<Stem::SurfacePoint> Stem::FirstSurfacePoint(const RayOrigin& origin,
                                                          const Eigen::Vector3d& d, double t_min,
                                                          double t_max, double tol_per_m) const {
  const Eigen::Vector3d& os = origin.o_stem;
  const Eigen::Vector3d ds = stem_from_world_ * d;
  const double ox = origin.ox, oy = origin.oy;
  const double dx = (ds.x() * cos_ell_ + ds.y() * sin_ell_) * inv_a_unit_;
  const double dy = (-ds.x() * sin_ell_ + ds.y() * cos_ell_) * inv_b_unit_;
  const double qa = dx * dx + dy * dy;
  if (qa < 1e-14) return std::nullopt;
  const double inv_qa = 1.0 / qa;
  const double qb = ox * dx + oy * dy;
  const double qc0 = ox * ox + oy * oy;
  if (envelope_bound_m_ > 0 && std::isfinite(t_max)) {
    // Nothing on the ray comes within tolerance of the surface if its closest approach to the
    // axis (scaled frame: real distances are at least b_unit_ times these) stays out of reach of
    // the widest envelope. Saves the radius iterations below for the many rays that pass by.
    const double reach =
        (a_unit_ * envelope_bound_m_ + std::max(3e-5, tol_per_m * t_max)) * inv_b_unit_ + 1e-6;
    if (qc0 - qb * qb * inv_qa > reach * reach) return std::nullopt;
  }
  double t_closest = -qb * inv_qa;
  double r = MeanRadius(os.z() + t_closest * ds.z());
  double t_in = 0.0, t_out = 0.0;
  bool ok = false;
  for (int it = 0; it < 4; ++it) {
    const double disc = qb * qb - qa * (qc0 - r * r);
    if (disc < 0) break;
    const double sq = std::sqrt(disc);
    t_in = (-qb - sq) * inv_qa;
    t_out = (-qb + sq) * inv_qa;
    ok = true;
    const double r_next = MeanRadius(os.z() + t_in * ds.z());
    if (std::abs(r_next - r) < 1e-5) break;
    r = std::max(r, r_next);  // grow only: never start inside the surface
  }
  if (!ok) return std::nullopt;
  double t = std::max(t_in - 0.002, t_min);
  const double t_end = std::min(t_out + 0.002, t_max);
  if (t >= t_end) return std::nullopt;
  FieldParts parts;  // of the field at t
  double f = Field(os + t * ds, &parts);
  for (int back = 0; f < 0 && back < 4 && t > t_min; ++back) {
    t = std::max(t - 0.03, t_min);
    f = Field(os + t * ds, &parts);
  }
  double t_prev = t;
  bool found = false;
  for (int it = 0; it < 64 && t <= t_end; ++it) {
    if (f < 0.0) {
      // Overshot: bisect between the last outside point and here.
      double lo = t_prev, hi = t;
      FieldParts mid_parts;
      for (int b = 0; b < 12; ++b) {
        const double mid = 0.5 * (lo + hi);
        if (Field(os + mid * ds, &mid_parts) < 0.0) {
          hi = mid;
          parts = mid_parts;
        } else {
          lo = mid;
        }
      }
      t = hi;
      found = true;
      break;
    }
    if (f < std::max(3e-5, tol_per_m * t)) {
      found = true;
      break;
    }
    t_prev = t;
    // Over-relaxed: twice the Lipschitz-safe step; an overshoot is caught by the sign test above.
    t += std::max(2.0 * f / march_lipschitz_, 2e-5);
    f = Field(os + t * ds, &parts);
  }
  if (!found || t > t_end || t < t_min) return std::nullopt;
  return SurfacePoint{t, os + t * ds, parts};
}

StemHit Stem::Shade(const SurfacePoint& point) const {
  // Normal from the field's gradient in cylindrical coordinates, F = rho - S(phi, s):
  // grad F = e_rho - (dS/dphi / rho) e_phi - (dS/ds) e_z.
  const Eigen::Vector3d& q = point.q_stem;
  FieldParts parts = point.parts;
  if (!parts.valid) {
    parts.valid = true;
    parts.rho = std::sqrt(q.x() * q.x() + q.y() * q.y());
    parts.u = TurnFraction(q.x(), q.y());
    parts.mean_radius = MeanRadius(q.z());
    parts.relief = Relief(parts.u, q.z());
  }
  const double rho = std::max(parts.rho, 1e-9);
  const double u = parts.u;
  const double relief = parts.relief;
  // S = E(phi) M(s) + relief, each part differentiated exactly.
  const Eigen::Vector3d e_rho(q.x() / rho, q.y() / rho, 0.0), e_phi(-e_rho.y(), e_rho.x(), 0.0);
  double de_dphi;
  const double e = EllipseFactor(e_rho.x(), e_rho.y(), &de_dphi);
  double dm_ds;
  MeanRadius(q.z(), &dm_ds);
  double relief_grad[2];
  Relief(u, q.z(), relief_grad);
  const double dS_dphi = de_dphi * parts.mean_radius + relief_grad[0] / kTwoPi;
  const double dS_ds = e * dm_ds + relief_grad[1];
  const Eigen::Vector3d grad = e_rho - (dS_dphi / rho) * e_phi - dS_ds * Eigen::Vector3d::UnitZ();
  StemHit hit;
  hit.t = point.t;
  hit.normal_world = world_from_stem_ * grad.normalized();
  hit.albedo = Albedo(u, q.z(), relief);
  return hit;
}

double Stem::EnvelopeEntry(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  const Eigen::Quaterniond stem_from_world = world_from_stem_.conjugate();
  const Eigen::Vector3d os = stem_from_world * (o - p_.base_world);
  const Eigen::Vector3d ds = stem_from_world * d;
  const double a = ds.x() * ds.x() + ds.y() * ds.y();
  if (a < 1e-12) return std::numeric_limits<double>::infinity();
  double t = -(os.x() * ds.x() + os.y() * ds.y()) / a;
  // Two passes: the radius depends on the height where the ray meets the stem.
  for (int pass = 0; pass < 2; ++pass) {
    const double s = os.z() + t * ds.z();
    if (s < -kBelowGroundM || s > p_.height_m) return std::numeric_limits<double>::infinity();
    double t0, t1;
    if (!CylinderSpan(os, ds, MeanRadius(s), &t0, &t1)) {
      return std::numeric_limits<double>::infinity();
    }
    t = t0;
  }
  return t > 0 ? t : std::numeric_limits<double>::infinity();
}

Eigen::Vector3f Stem::Albedo(double u, double s, double relief) const {
  const double furrow = std::clamp(-relief / std::max(p_.furrow_depth_m, 1e-4), 0.0, 1.0);
  const double tint = 1.0 + 0.22 * noise_.Fbm2PeriodicX(u * 8.0, 3.0 * s, 8, 2);
  Eigen::Vector3f rgb = p_.bark_rgb * static_cast<float>(tint * (1.0 - 0.65 * furrow));
  // Pale lichen patches, more on plates than in furrows.
  const double l = noise_.Fbm2PeriodicX(u * 14.0, 5.0 * s + 40.0, 14, 2);
  const double lichen_cover =
      std::clamp((l - (0.55 - 0.8 * p_.lichen)) * 6.0, 0.0, 1.0) * (1.0 - 0.5 * furrow);
  rgb = rgb * (1.0f - static_cast<float>(lichen_cover)) +
        Eigen::Vector3f(0.52f, 0.55f, 0.48f) * static_cast<float>(lichen_cover);
  // Moss around the base, patchy.
  if (s < 0.8 && p_.moss > 0) {
    const double m = noise_.Noise2PeriodicX(u * 6.0, 2.0 * s + 80.0, 6);
    const double moss_cover =
        std::clamp((m + p_.moss - 0.3) * 3.0, 0.0, 1.0) * std::clamp((0.8 - s) / 0.5, 0.0, 1.0);
    rgb = rgb * (1.0f - static_cast<float>(moss_cover)) +
          Eigen::Vector3f(0.10f, 0.17f, 0.05f) * static_cast<float>(moss_cover);
  }
  return rgb;
}

Stem::Section Stem::MeasureSection(double s, const Eigen::Vector2d& view_xy) const {
  constexpr int kSamples = 2880;
  std::vector<Eigen::Vector2d> pts(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    const double phi = kTwoPi * k / kSamples;
    const double r = SurfaceRadius(phi, s);
    pts[k] = {r * std::cos(phi), r * std::sin(phi)};
  }
  // The outline is star-shaped and sorted by angle; a monotone stack keeps its convex hull.
  std::vector<Eigen::Vector2d> hull;
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  // Start from the farthest point, which is surely on the hull.
  int start = 0;
  for (int k = 1; k < kSamples; ++k) {
    if (pts[k].squaredNorm() > pts[start].squaredNorm()) start = k;
  }
  for (int i = 0; i <= kSamples; ++i) {
    const Eigen::Vector2d& p = pts[(start + i) % kSamples];
    while (hull.size() >= 2 && cross(hull[hull.size() - 2], hull.back(), p) <= 0) hull.pop_back();
    hull.push_back(p);
  }
  Section out{0.0, 0.0, 1e9, 0.0};
  for (size_t i = 0; i + 1 < hull.size(); ++i) out.girth_m += (hull[i + 1] - hull[i]).norm();
  for (int k = 0; k < 720; ++k) {
    const double a = std::numbers::pi * k / 720;
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    double lo = 1e9, hi = -1e9;
    for (const auto& p : hull) {
      lo = std::min(lo, p.dot(dir));
      hi = std::max(hi, p.dot(dir));
    }
    out.major_m = std::max(out.major_m, hi - lo);
    out.minor_m = std::min(out.minor_m, hi - lo);
  }
  // The direction across the view, in the section's plane.
  const Eigen::Vector3d across_stem =
      world_from_stem_.inverse() * Eigen::Vector3d(-view_xy.y(), view_xy.x(), 0.0);
  const Eigen::Vector2d across = across_stem.head<2>().normalized();
  double lo = 1e9, hi = -1e9;
  for (const auto& p : hull) {
    lo = std::min(lo, p.dot(across));
    hi = std::max(hi, p.dot(across));
  }
  out.across_m = hi - lo;
  return out;
}

}  // namespace stemmap::sim
