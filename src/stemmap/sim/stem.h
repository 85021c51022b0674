#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "stemmap/core/fast_math.h"
#include "stemmap/core/noise.h"

namespace stemmap::sim {

// Shape and bark of one stem. Lengths in metres, along the (possibly leaning) stem axis.
struct StemParams {
  Eigen::Vector3d base_world = Eigen::Vector3d::Zero();  // axis point at the ground
  double lean_rad = 0.0;
  double lean_azimuth_rad = 0.0;
  double radius_bh_m = 0.15;         // mean radius of the ellipse at s = s_bh_m
  double s_bh_m = 1.37;              // axis coordinate of breast height
  double taper_m_per_m = 0.005;      // radius lost per metre of height
  double axis_ratio = 1.0;           // minor / major of the elliptical section, <= 1
  double ellipse_azimuth_rad = 0.0;  // major axis direction in the stem frame
  double flare = 0.3;                // extra radius at the ground, as a fraction of radius_bh
  double flare_height_m = 0.35;      // e-folding height of the root flare
  double furrow_depth_m = 0.004;     // bark relief; furrows cut inward from the outer envelope
  double furrow_spacing_m = 0.03;
  double height_m = 20.0;                            // stem top (hidden in the canopy)
  Eigen::Vector3f bark_rgb = {0.35f, 0.30f, 0.26f};  // linear albedo of the plates
  double lichen = 0.2;                               // share of bark covered by pale lichen
  double moss = 0.2;                                 // moss near the base
  uint64_t seed = 0;
};

struct StemHit {
  double t = 0.0;                // ray parameter
  Eigen::Vector3d normal_world;  // outward
  Eigen::Vector3f albedo;        // linear RGB
};

// A stem as an implicit surface in its own frame (z along the axis): a point is inside when its
// radial distance is below SurfaceRadius(azimuth, s). The renderer marches rays against it.
class Stem {
 public:
  explicit Stem(const StemParams& p);

  const StemParams& params() const { return p_; }
  // Outer envelope and relief: radius of the surface at azimuth `phi` (stem frame), height `s`.
  double SurfaceRadius(double phi, double s) const;
  // Largest surface radius at or above height s (for bounding).
  double BoundRadius(double s) const;
  // World position of the axis at axis coordinate s.
  Eigen::Vector3d AxisPoint(double s) const { return p_.base_world + s * axis_world_; }
  const Eigen::Vector3d& axis_world() const { return axis_world_; }

  // What the field computes at a point, kept so that a hit's normal and albedo reuse it.
  struct FieldParts {
    bool valid = false;  // false where the field short-cuts (beyond the ends, on the axis)
    double rho, u, mean_radius, relief;
  };
  // Where a ray meets the surface, before any shading: enough to tell which object is nearest.
  struct SurfacePoint {
    double t = 0.0;          // ray parameter
    Eigen::Vector3d q_stem;  // the point, stem frame
    FieldParts parts;        // of the field at q_stem
  };

  // First intersection of the ray o + t d (|d| = 1) with t in (t_min, t_max). The surface is
  // located to `tol_per_m` × t (a fraction of the pixel footprint is plenty).
  std::optional<StemHit> Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                                   double t_max, double tol_per_m = 1e-5) const;
  // Intersect() in two parts: the march, and the normal and albedo where it ended. Shading only
  // the nearest of several stems along a ray, or none when only the hit matters, saves the bark
  // lookups the shading needs.
  std::optional<SurfacePoint> FirstSurfacePoint(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                                double t_min, double t_max,
                                                double tol_per_m = 1e-5) const;
  // A ray origin in the stem's frames, for the many rays of one camera position.
  struct RayOrigin {
    Eigen::Vector3d o_stem;  // stem frame
    double ox, oy;           // scaled so that the envelope's section is a circle
  };
  RayOrigin PrepareOrigin(const Eigen::Vector3d& o_world) const;
  std::optional<SurfacePoint> FirstSurfacePoint(const RayOrigin& o, const Eigen::Vector3d& d,
                                                double t_min, double t_max,
                                                double tol_per_m = 1e-5) const;
  StemHit Shade(const SurfacePoint& point) const;
  // Entry distance of the ray into the stem's smooth envelope (no bark relief), or infinity.
  // Cheap enough to fill a shadow map.
  double EnvelopeEntry(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const;

  // Truth at axis coordinate s: girth of the convex hull of the section perpendicular to the axis,
  // the largest and smallest caliper widths, and the caliper width seen looking along the
  // horizontal world direction `view_xy` (what a silhouette from that side shows).
  struct Section {
    double girth_m;
    double major_m;
    double minor_m;
    double across_m;
  };
  Section MeasureSection(double s, const Eigen::Vector2d& view_xy = Eigen::Vector2d::UnitX()) const;

 private:
  // Mean radius at height s, and its derivative along s where `slope` is given.
  double MeanRadius(double s, double* slope = nullptr) const;
  // Bark relief (<= 0) at turn fraction u = azimuth / 2π in [0, 1) and height s; with its
  // derivatives in u and s where `grad` is given.
  double Relief(double u, double s, double* grad = nullptr) const;
  // Radius of the unit-mean ellipse at azimuth phi, and its derivative in phi where asked.
  double EllipseFactor(double cos_phi, double sin_phi, double* slope = nullptr) const;
  // Each bark ridge's plates: their length and the offset of their cracks, from a hash of the
  // ridge; tabulated for the stem's ridges, whose hashes would otherwise be most of a lookup.
  struct Plates {
    double length_m, offset;
  };
  static constexpr int64_t kFirstRidge = -2;
  Plates HashPlates(int64_t ridge) const;
  Plates RidgePlates(int64_t ridge) const {
    const uint64_t k = static_cast<uint64_t>(ridge - kFirstRidge);
    return k < plates_.size() ? plates_[k] : HashPlates(ridge);
  }
  double Field(const Eigen::Vector3d& p_stem, FieldParts* parts = nullptr) const;  // < 0 inside
  Eigen::Vector3f Albedo(double u, double s, double relief) const;  // relief = Relief(u, s)
  static double TurnFraction(double x, double y);

  StemParams p_;
  Eigen::Quaterniond world_from_stem_;
  Eigen::Matrix3d stem_from_world_;  // the same rotation, inverted, as a matrix (per ray)
  Eigen::Vector3d axis_world_;
  double a_unit_, b_unit_;  // ellipse semi-axes for unit mean radius
  double inv_a_unit_, inv_b_unit_, inv_flare_height_, flare_top_m_;
  const ExpNegTable* exp_neg_;  // the shared table, looked up once
  double cos_ell_, sin_ell_;
  int n_furrows_;
  std::vector<Plates> plates_;  // RidgePlates() from kFirstRidge on
  double march_lipschitz_;
  double envelope_bound_m_;  // largest mean radius over the stem's length, or -1 if unknown
  ValueNoise noise_;
};

}  // namespace stemmap::sim
