#include "stemmap/track/loop_closure.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <opencv2/features2d.hpp>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/track/rotation.h"

namespace stemmap::track {

void LoopOptions::Check() const {
  if (!(ratio > 0 && ratio < 1)) throw InputError("loop ratio test must lie in (0, 1)");
  if (min_inliers < 8) throw InputError("loop closure needs at least 8 inliers");
  if (!(search_min_turn > 0.5 && search_max_turn > search_min_turn)) {
    throw InputError("loop search range must satisfy 0.5 < min < max turns");
  }
}

bool VerifyLoopPair(const LoopOptions& o, const Keyframe& early, const Keyframe& late,
                    const PinholeCamera& camera, int early_index, int late_index, LoopPair* pair) {
  if (early.orb_descriptors.empty() || late.orb_descriptors.empty()) return false;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(early.orb_descriptors, late.orb_descriptors, knn, 2);
  std::vector<Eigen::Vector3d> a, b;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> px;
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance > o.ratio * m[1].distance) continue;
    const cv::Point2f& pa = early.orb_keypoints[m[0].queryIdx].pt;
    const cv::Point2f& pb = late.orb_keypoints[m[0].trainIdx].pt;
    px.emplace_back(Eigen::Vector2d(pa.x, pa.y), Eigen::Vector2d(pb.x, pb.y));
    a.push_back(camera.CamRayFromImage(px.back().first).normalized());
    b.push_back(camera.CamRayFromImage(px.back().second).normalized());
  }
  if (static_cast<int>(a.size()) < o.min_inliers) return false;
  const RotationFit fit = FitRotationRansac(a, b, o.threshold_deg * M_PI / 180.0, 300,
                                            HashCombine(early_index, late_index));
  const int n_in = static_cast<int>(fit.inliers.size());
  if (n_in < o.min_inliers || n_in < o.min_inlier_share * a.size()) return false;
  pair->early = early_index;
  pair->late = late_index;
  pair->inliers = n_in;
  pair->yaw_rad = YawOfRotation(fit.b_from_a);
  pair->matches.clear();
  for (int i : fit.inliers) pair->matches.push_back(px[i]);
  return true;
}

LoopResult FindLoops(const LoopOptions& o, const FrontendResult& f, const PinholeCamera& camera,
                     const std::vector<double>& turn) {
  o.Check();
  LoopResult result;
  const int n = static_cast<int>(f.keyframes.size());
  if (n < 3) return result;
  const double full = 2.0 * M_PI;
  const double sign = turn.back() >= 0 ? 1.0 : -1.0;
  // 1. The revisit of the first keyframe: the late keyframe that matches it best.
  LoopPair best;
  for (int j = 1; j < n; ++j) {
    const double a = sign * turn[j];
    if (a < o.search_min_turn * full || a > o.search_max_turn * full) continue;
    LoopPair p;
    if (VerifyLoopPair(o, f.keyframes[0], f.keyframes[j], camera, 0, j, &p) &&
        p.inliers > best.inliers) {
      best = p;
    }
  }
  if (best.inliers == 0) return result;
  result.apparent_per_turn_rad =
      sign * (turn[best.late] - turn[0]) / (full + sign * best.yaw_rad) * full;
  // 2. Every early keyframe in the overlap: its revisit predicted from that factor, verified.
  for (int i = 0; i < n; ++i) {
    const double target = turn[i] + sign * result.apparent_per_turn_rad;
    if (sign * (target - turn.back()) > 0) break;
    int j = static_cast<int>(
        std::lower_bound(turn.begin(), turn.end(), target,
                         [sign](double x, double t) { return sign * x < sign * t; }) -
        turn.begin());
    LoopPair best_i;
    for (int jj = std::max(i + 1, j - 1); jj <= std::min(n - 1, j + 1); ++jj) {
      LoopPair p;
      if (VerifyLoopPair(o, f.keyframes[i], f.keyframes[jj], camera, i, jj, &p) &&
          p.inliers > best_i.inliers) {
        best_i = p;
      }
    }
    if (best_i.inliers > 0) result.pairs.push_back(std::move(best_i));
  }
  spdlog::debug("loop: {} verified pairs, apparent turn {:.1f}° per turn", result.pairs.size(),
                result.apparent_per_turn_rad * 180 / M_PI);
  return result;
}

namespace {

// Index of the track observed within `radius_px` of `px` in keyframe `kf`, or -1.
int NearestTrack(const std::vector<std::vector<std::pair<int, Eigen::Vector2d>>>& by_kf, int kf,
                 const Eigen::Vector2d& px, double radius_px) {
  int best = -1;
  double best_d = radius_px;
  for (const auto& [track, p] : by_kf[kf]) {
    const double d = (p - px).norm();
    if (d < best_d) {
      best_d = d;
      best = track;
    }
  }
  return best;
}

int Find(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace

void MergeLoopTracks(const LoopOptions& o, FrontendResult& f, LoopResult& loop) {
  const int n_tracks = static_cast<int>(f.tracks.size());
  std::vector<std::vector<std::pair<int, Eigen::Vector2d>>> by_kf(f.keyframes.size());
  for (int t = 0; t < n_tracks; ++t) {
    // Where the pictures show them: the ORB keypoints are found in the pictures.
    for (const Observation& ob : f.tracks[t].obs) {
      by_kf[ob.keyframe].emplace_back(t, ob.px + ob.picture_offset_px);
    }
  }
  std::vector<int> parent(n_tracks);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::vector<Observation>> extra(n_tracks);
  for (const LoopPair& p : loop.pairs) {
    for (const auto& [pe, pl] : p.matches) {
      const int te = NearestTrack(by_kf, p.early, pe, o.merge_radius_px);
      if (te < 0) continue;
      const int tl = NearestTrack(by_kf, p.late, pl, o.merge_radius_px);
      if (tl >= 0) {
        const int re = Find(parent, te), rl = Find(parent, tl);
        if (re != rl) {
          parent[rl] = re;
          ++loop.merged_tracks;
        }
      } else {
        // At the frame's time, as the tracks' observations are (a rolling shutter), with the
        // picture's velocity: the keypoint's own is not known.
        const Eigen::Vector2d at = AtFrameTime(pl, f.keyframes[p.late].picture_px_per_s,
                                               f.readout_s, f.working_size.height);
        extra[te].push_back({p.late, at, pl - at});
        ++loop.extended_tracks;
      }
    }
  }
  std::map<int, std::vector<Observation>> joined;
  for (int t = 0; t < n_tracks; ++t) {
    std::vector<Observation>& dst = joined[Find(parent, t)];
    dst.insert(dst.end(), f.tracks[t].obs.begin(), f.tracks[t].obs.end());
    dst.insert(dst.end(), extra[t].begin(), extra[t].end());
  }
  std::map<int, int> index_of_root;
  for (const auto& [root, obs] : joined) index_of_root.emplace(root, index_of_root.size());
  for (FrameObservations& b : f.between) {
    for (int& t : b.track) t = index_of_root.at(Find(parent, t));
  }
  std::vector<Track> out;
  out.reserve(joined.size());
  for (auto& [root, obs] : joined) {
    std::sort(obs.begin(), obs.end(),
              [](const Observation& a, const Observation& b) { return a.keyframe < b.keyframe; });
    // A keyframe seen twice means two different points were joined: keep the first run only.
    bool clash = false;
    for (size_t k = 1; k < obs.size(); ++k) clash |= obs[k].keyframe == obs[k - 1].keyframe;
    if (clash) {
      obs.erase(std::unique(obs.begin(), obs.end(),
                            [](const Observation& a, const Observation& b) {
                              return a.keyframe == b.keyframe;
                            }),
                obs.end());
    }
    out.push_back({std::move(obs)});
  }
  f.tracks = std::move(out);
}

}  // namespace stemmap::track
