#include "stemmap/dense/dense.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/progress.h"
#include "stemmap/dense/cloud_io.h"
#include "stemmap/dense/trunk_mask.h"

namespace stemmap::dense {

void DenseOptions::Check() const {
  stereo.Check();
  if (!(pair_turn_deg >= 2.0 && pair_turn_deg <= 40.0)) {
    throw InputError(fmt::format("stereo pair turn {}° must lie in 2-40°", pair_turn_deg));
  }
  if (!(reference_step_deg > 0)) throw InputError("reference step must be positive");
  if (near_pair_turn_deg != 0 && !(near_pair_turn_deg >= 2.0 && near_pair_turn_deg <= 40.0)) {
    throw InputError(
        fmt::format("near stereo pair turn {}° must be 0 or lie in 2-40°", near_pair_turn_deg));
  }
  if (!(near_min_depth_m > 0 && near_max_depth_m > near_min_depth_m)) {
    throw InputError("near stereo depths must be positive and increasing");
  }
  if (short_baseline_max_depth_m != 0 && !(short_baseline_max_depth_m > near_max_depth_m)) {
    throw InputError("the short-baseline depth limit must be 0 or beyond the near pairs' range");
  }
  if (!(pair_threads >= 1 && pair_threads <= 64)) {
    throw InputError(fmt::format("stereo pair threads {} must lie in 1-64", pair_threads));
  }
}

namespace {

// Heading (rad) of a camera's optical axis about the plot's z.
double Heading(const Rigid3d& world_from_cam) {
  const Eigen::Vector3d f = world_from_cam.rotation * Eigen::Vector3d::UnitZ();
  return std::atan2(f.y(), f.x());
}

// Reference keyframes every `step` of turn (one turn's worth), each paired with the later keyframe
// nearest `pair` of turn beyond it (within a quarter of it). Headings unwrapped, in rad.
std::vector<std::pair<int, int>> SelectPairs(const std::vector<double>& heading, double pair,
                                             double step) {
  const int n = static_cast<int>(heading.size());
  const double sign = heading.back() >= heading.front() ? 1.0 : -1.0;
  std::vector<std::pair<int, int>> pairs;
  double next_ref = heading[0];
  for (int k = 0; k < n; ++k) {
    if (sign * (heading[k] - next_ref) < 0) continue;
    // Stop one turn after the start: the rest sees the same trees again.
    if (sign * (heading[k] - heading[0]) > 2 * M_PI) break;
    int best = -1;
    double best_err = 0.25 * pair;
    for (int j = k + 1; j < n && sign * (heading[j] - heading[k]) < 1.5 * pair; ++j) {
      const double err = std::abs(sign * (heading[j] - heading[k]) - pair);
      if (err < best_err) {
        best_err = err;
        best = j;
      }
    }
    if (best >= 0) {
      pairs.emplace_back(k, best);
      next_ref = heading[k] + sign * step;
    }
  }
  return pairs;
}

}  // namespace

DenseResult RunDense(const DenseOptions& o, const DenseInput& in,
                     const std::filesystem::path& out_dir) {
  o.Check();
  const auto start = std::chrono::steady_clock::now();
  const int n = static_cast<int>(in.keyframes.size());
  if (n < 2) throw ProcessingError("dense depth needs at least two keyframes");
  if (in.images.size() != in.keyframes.size()) {
    throw ProcessingError("dense depth needs one image slot per keyframe");
  }
  // Unwrapped headings, so "this much turn later" is a simple search.
  std::vector<double> heading(n);
  for (int k = 0; k < n; ++k) {
    heading[k] = Heading(in.keyframes[k].world_from_cam);
    if (k > 0) heading[k] = heading[k - 1] + std::remainder(heading[k] - heading[k - 1], 2 * M_PI);
  }
  struct Pair {
    int a, b;
    const StereoOptions* stereo;
  };
  std::vector<Pair> pairs;
  StereoOptions near_stereo = o.stereo;
  near_stereo.min_depth_m = o.near_min_depth_m;
  near_stereo.max_depth_m = o.near_max_depth_m;
  for (const auto& [turn_deg, stereo] :
       {std::pair{o.pair_turn_deg, &o.stereo},
        std::pair{o.near_pair_turn_deg, static_cast<const StereoOptions*>(&near_stereo)}}) {
    if (turn_deg <= 0) continue;
    for (const auto& [a, b] :
         SelectPairs(heading, turn_deg * M_PI / 180.0, o.reference_step_deg * M_PI / 180.0)) {
      pairs.push_back({a, b, stereo});
    }
  }
  DenseResult r;
  r.depth_focal_px = in.camera.fx * o.stereo.scale / o.stereo.pixel_step;
  Progress progress("depth", static_cast<int64_t>(pairs.size()));
  // Several pairs at a time (pair_threads), each into its own slot and gathered in pair order, so
  // the cloud does not depend on the threads. A mask model is run from one thread.
  struct PairPoints {
    bool done = false;
    std::vector<CloudPoint> points, short_baseline;
    std::exception_ptr error;
  };
  std::vector<PairPoints> per_pair(pairs.size());
  int64_t finished = 0;
#pragma omp parallel for schedule(dynamic) num_threads(o.pair_threads) if (in.mask_model == nullptr)
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto [a, b, stereo] = pairs[i];
    const cv::Mat &ia = in.images[a], &ib = in.images[b];
    PairPoints& out = per_pair[i];
    try {
      if (!ia.empty() && !ib.empty()) {
        const bool near = stereo == &near_stereo;
        out.points = StereoPairPoints(*stereo, ia, ib, in.camera, in.keyframes[a].world_from_cam,
                                      in.keyframes[b].world_from_cam, a,
                                      near ? o.short_baseline_max_depth_m : 0.0,
                                      near ? &out.short_baseline : nullptr);
        if (in.mask_model != nullptr) {
          LabelTrunkPoints(in.mask_model->Predict(ia), in.camera, in.keyframes[a].world_from_cam,
                           &out.points);
        }
        out.done = true;
      }
    } catch (...) {
      out.error = std::current_exception();  // an exception must not leave the parallel loop
    }
#pragma omp critical(dense_progress)
    {
      try {
        progress.Update(++finished);
      } catch (...) {
        if (!out.error) out.error = std::current_exception();
      }
    }
  }
  // Gathered into one cloud sized once, each pair's points freed as they are copied, so the
  // pairs' copies and the cloud are not held in full together.
  size_t total = 0;
  for (const PairPoints& p : per_pair) {
    if (p.error) std::rethrow_exception(p.error);
    total += p.points.size();
  }
  r.points.reserve(total);
  int masked = 0;
  for (PairPoints& p : per_pair) {
    if (!p.done) continue;
    r.points.insert(r.points.end(), p.points.begin(), p.points.end());
    r.short_baseline_points.insert(r.short_baseline_points.end(), p.short_baseline.begin(),
                                   p.short_baseline.end());
    std::vector<CloudPoint>().swap(p.points);
    std::vector<CloudPoint>().swap(p.short_baseline);
    masked += in.mask_model != nullptr;
    ++r.pairs;
  }
  progress.Finish();
  if (r.pairs == 0) throw ProcessingError("no keyframe images found for stereo (timestamps?)");
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.summary = {{"pairs", r.pairs},
               {"points", r.points.size()},
               {"short_baseline_points", r.short_baseline_points.size()},
               {"wall_s", wall}};
  if (in.mask_model != nullptr) {
    const auto on_trunk = std::count_if(r.points.begin(), r.points.end(),
                                        [](const CloudPoint& p) { return p.trunk == 1; });
    r.summary["mask_model"] = in.mask_model->Describe();
    r.summary["masked_keyframes"] = masked;
    r.summary["trunk_points"] = on_trunk;
  }
  r.summary["depth_focal_px"] = r.depth_focal_px;
  WriteCloudPly(out_dir / "cloud.ply", r.points);
  WriteCloudPly(out_dir / "cloud_coarse.ply", r.short_baseline_points);
  WriteJsonAtomic(out_dir / "dense_summary.json", r.summary);
  spdlog::info("dense: {} pairs, {} points in {:.1f} s", r.pairs, r.points.size(), wall);
  return r;
}

}  // namespace stemmap::dense
