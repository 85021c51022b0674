#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

// Keyframe poses and track points in the axis frame: origin at the centre of the arm circle,
// z along the rotation axis, camera centres near radius R in the plane z = 0.
struct SparseMap {
  std::vector<Eigen::Quaterniond> cam_from_world;
  std::vector<Eigen::Vector3d> centre_world;
  Eigen::Quaterniond arm_from_cam = Eigen::Quaterniond::Identity();  // the phone's mount
  double focal_scale = 1.0;  // refined focal length over the starting one
  // Each keyframe's focal length over the shared one (focus breathing: a phone's autofocus
  // changes the focal length as it follows near and far trunks). Empty: one focal length for
  // all. Where it is set, the bundle adjustment refines one per keyframe.
  std::vector<double> keyframe_focal_scale;
  // Keyframe k's focal length over the starting one.
  double FocalScaleAt(int k) const {
    return keyframe_focal_scale.empty() ? focal_scale : focal_scale * keyframe_focal_scale[k];
  }
  std::vector<Eigen::Vector3d> point_world;  // one per track
  std::vector<char> point_valid;             // 0 for tracks not (or no longer) triangulated
  std::vector<std::vector<char>> obs_valid;  // per track and observation: 0 once rejected
};

struct BundleOptions {
  double arm_radius_m = 1.0;
  double sigma_radius_m = 0.01;  // how far the stand lets the camera leave the circle
  double sigma_height_m = 0.01;
  double sigma_mount_deg = 0.7;  // wobble of the phone on the arm
  // KLT errors have a median near 0.4 px and a long tail (points on occluding edges slide): a
  // tight Huber threshold and dropping what is off by more than 1.5 px keep the tail from bending
  // the keyframe headings.
  double loss_px = 0.7;     // Huber threshold of the reprojection error
  double outlier_px = 1.5;  // observations above this are dropped between rounds
  // A track whose kept observations' rms error exceeds this (px) after a round is dropped whole
  // (0: none). A point that moves, a leaf or a twig of the understory in a breeze, keeps many of
  // its observations under `outlier_px`; on natural plots in a breeze such tracks pulled the
  // refined focal length up to 0.25 % long, which moves a stem 8 m out by up to 20 cm. A still
  // point's rms is the tracker's noise, median 0.4-0.5 px. Not in the first round, whose errors
  // are the starting poses' more than the tracks'.
  double max_track_rms_px = 0.6;
  double min_triangulation_deg = 1.0;
  int min_observations = 3;
  int max_points = 6000;
  int max_iterations = 40;
  // The solver stops when an iteration lowers the cost by less than this share of it. The rounds
  // before the last only decide which observations to drop and restart from their result, so a
  // looser tolerance there loses nothing: their last iterations move the cost by a few parts in
  // ten thousand, and take more than half of the adjustment's time.
  double function_tolerance = 1e-6;
  double early_round_function_tolerance = 1e-4;
  int dense_schur_max_keyframes = 400;  // beyond this the sparse Schur solver is used
  bool refine_focal = false;            // the closed loop makes the focal length observable
  // Where the map has per-keyframe focal lengths: how far (%, one SD) a keyframe's may differ
  // from the shared one. Phones breathe by up to about 1 %; a zoom of the picture about its
  // centre is told apart from a turn (a shift) and from a step forward (which moves near points
  // more than far ones), so the prior only keeps keyframes with few points in check.
  double sigma_keyframe_focal_pct = 2.0;
  // Observations where the lens squeezes the picture radially to less than this share of its
  // scale at the centre (dr_distorted / dr_undistorted, a wide lens's outer edge) are left out of
  // the adjustment: there a calibration's small error in its polynomial is a large one in angle
  // (on a 100° lens calibrated from a board video, 0.08° at the picture's side edge against
  // 0.005° at 0.83 of the way out), and points enter and leave the view there, so the focal
  // length settled half a percent off and stems 10 m out moved by decimetres.
  double min_lens_scale = 0.6;
  // Ceres sums over threads in whatever order they finish: more than one thread is faster but
  // the result then changes in its last digits from run to run.
  int threads = 1;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(BundleOptions, arm_radius_m, sigma_radius_m,
                                                sigma_height_m, sigma_mount_deg, loss_px,
                                                outlier_px, max_track_rms_px, min_triangulation_deg,
                                                min_observations, max_points, max_iterations,
                                                function_tolerance, early_round_function_tolerance,
                                                dense_schur_max_keyframes, refine_focal,
                                                sigma_keyframe_focal_pct, min_lens_scale, threads)

struct BundleSummary {
  int points = 0, observations = 0, rejected_observations = 0, iterations = 0;
  int rejected_points = 0;  // tracks dropped whole (max_track_rms_px)
  double initial_rms_px = 0.0, final_rms_px = 0.0;
  bool converged = false;
  std::string BriefReport() const;
};

// Nominal mount: camera looking outward along the arm, image x pointing against the turn.
Eigen::Quaterniond NominalArmFromCam();

// Poses on the circle at arm angles `phi_rad` with the nominal mount.
void PlaceOnCircle(const std::vector<double>& phi_rad, double radius_m, SparseMap* map);

// (Re)triangulates every track whose point is not valid, from the current poses.
int TriangulateTracks(const BundleOptions& o, const std::vector<Track>& tracks,
                      const PinholeCamera& camera, SparseMap* map);

// Circle-constrained bundle adjustment over all keyframes and points; then drops observations
// with errors above `outlier_px` and points left with too few of them.
BundleSummary RunBundleAdjustment(const BundleOptions& o, const std::vector<Track>& tracks,
                                  const PinholeCamera& camera, SparseMap* map);

// How far (%) each keyframe's focal scale strays from the keyframes' median, |s_k / median - 1|.
// An autofocus pulls the focal length by up to about 1 % for the moments a near trunk fills the
// middle of the view; a fixed focus leaves the estimates' noise, about 0.1 % at most at 960x540.
std::vector<double> FocalScaleStrayPct(const std::vector<double>& scales);

// The lens's radial scale at a pixel, d r_distorted / d r_undistorted = g + 2 rho g'(rho) at
// the pixel's undistorted rho = |p|^2 (1 for a lens without distortion).
double LensRadialScale(const PinholeCamera& camera, const Eigen::Vector2d& px);

// Reprojection error (px) of one observation under the current map.
double ReprojectionErrorPx(const SparseMap& map, const PinholeCamera& camera, int keyframe,
                           const Eigen::Vector3d& point_world, const Eigen::Vector2d& px);

}  // namespace stemmap::track
