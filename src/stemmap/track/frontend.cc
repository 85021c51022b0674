#include "stemmap/track/frontend.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <thread>

#include "stemmap/core/error.h"
#include "stemmap/core/progress.h"

namespace stemmap::track {

void FrontendOptions::Check() const {
  if (working_long_side_px < 160) {
    throw InputError(
        fmt::format("working resolution {} px is too small (>= 160)", working_long_side_px));
  }
  if (!(track_fps > 0)) throw InputError("track fps must be positive");
  if (max_features < 50) throw InputError("max features must be at least 50");
  if (lk_window_px < 5 || lk_refine_window_px < 3 || lk_levels < 0 || lk_refine_levels < 0) {
    throw InputError("KLT windows must be at least 5 and 3 px, pyramid levels non-negative");
  }
  if (!(keyframe_step_deg > 0.2 && keyframe_step_deg < 20)) {
    throw InputError(fmt::format("keyframe step {}° must lie in (0.2, 20)", keyframe_step_deg));
  }
  if (!(readout_ms >= 0 && readout_ms <= 100)) {
    throw InputError(fmt::format("--readout-ms {} must lie in [0, 100] ms", readout_ms));
  }
}

Eigen::Vector2d AtFrameTime(const Eigen::Vector2d& px, const Eigen::Vector2d& px_per_s,
                            double readout_s, int rows) {
  if (readout_s <= 0 || rows < 2) return px;
  const double after_s = readout_s * (px.y() / (rows - 1) - 0.5);
  return px - after_s * px_per_s;
}

namespace {

// The median of `v` (0 when empty); reorders it.
float Median(std::vector<float>* v) {
  if (v->empty()) return 0.f;
  std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
  return (*v)[v->size() / 2];
}

// Adds to `spans` the stretches where frames are missing (packets the decoder rejected): gaps
// between decoded frames over 2.5 frame intervals, as (last frame before, first frame after).
void AddMissingSpans(double fps, const std::vector<double>& frame_t_s,
                     std::vector<std::pair<double, double>>* spans) {
  if (!(fps > 0)) return;
  for (size_t i = 1; i < frame_t_s.size(); ++i) {
    if (frame_t_s[i] - frame_t_s[i - 1] > 2.5 / fps) {
      spans->emplace_back(frame_t_s[i - 1], frame_t_s[i]);
    }
  }
  std::sort(spans->begin(), spans->end());
  // Overlapping stretches (damaged frames next to missing ones) become one.
  std::vector<std::pair<double, double>> merged;
  for (const auto& s : *spans) {
    if (!merged.empty() && s.first <= merged.back().second) {
      merged.back().second = std::max(merged.back().second, s.second);
    } else {
      merged.push_back(s);
    }
  }
  *spans = std::move(merged);
}

struct Tracker {
  Tracker(const FrontendOptions& options, const PinholeCamera& cam) : o(options), camera(cam) {}
  const FrontendOptions& o;
  const PinholeCamera& camera;
  std::vector<cv::Point2f> pts;    // alive points in the current tracked frame
  std::vector<int> ids;            // their track ids
  std::vector<cv::Point2f> at_kf;  // their position at the last keyframe (x < 0: born later)
  std::vector<cv::Point2f> vel;    // their image velocity (px/s) from the frame before
  // Whether the point was born at the last keyframe and has not been tracked since: its one
  // observation was moved to the frame's time with the picture's median velocity, a guess that
  // is wrong for a point nearer or farther than most (its velocity differs by the parallax).
  std::vector<uint8_t> newborn;
  cv::Point2f frame_vel{0.f, 0.f};  // the median of the points' velocities
  std::vector<std::vector<Observation>> tracks;
  size_t alive_at_kf = 0;

  // Point i where it was at the frame's time (FrontendOptions::readout_ms).
  Eigen::Vector2d AtFrameTime(size_t i, int rows) const {
    return track::AtFrameTime({pts[i].x, pts[i].y}, {vel[i].x, vel[i].y}, 1e-3 * o.readout_ms,
                              rows);
  }

  double AzimuthRad(const cv::Point2f& p) const { return std::atan((p.x - camera.cx) / camera.fx); }

  // Median apparent rotation (rad) of the points seen at the last keyframe.
  double RotationSinceKeyframe(size_t* n_common) const {
    std::vector<double> d;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (at_kf[i].x >= 0) d.push_back(AzimuthRad(pts[i]) - AzimuthRad(at_kf[i]));
    }
    *n_common = d.size();
    if (d.empty()) return 0.0;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d[d.size() / 2];
  }

  void Seed(const cv::Mat& gray) {
    const int want = o.max_features - static_cast<int>(pts.size());
    if (want < o.max_features / 8) return;
    cv::Mat mask(gray.size(), CV_8U, cv::Scalar(255));
    for (const cv::Point2f& p : pts) {
      cv::circle(mask, p, static_cast<int>(o.min_feature_distance_px), cv::Scalar(0), -1);
    }
    std::vector<cv::Point2f> fresh;
    cv::goodFeaturesToTrack(gray, fresh, want, o.feature_quality, o.min_feature_distance_px, mask,
                            5);
    for (const cv::Point2f& p : fresh) {
      pts.push_back(p);
      ids.push_back(static_cast<int>(tracks.size()));
      at_kf.emplace_back(-1.f, -1.f);
      vel.push_back(frame_vel);  // a new point moves as the picture does, at first
      newborn.push_back(1);
      tracks.emplace_back();
    }
  }

  void RecordKeyframe(int kf, int rows) {
    for (size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector2d at = AtFrameTime(i, rows);
      tracks[ids[i]].push_back({kf, at, Eigen::Vector2d(pts[i].x, pts[i].y) - at});
      at_kf[i] = pts[i];
    }
    alive_at_kf = pts.size();
  }

  // Point i, born at the last keyframe and now followed one step, has its own velocity
  // `px_per_s`: its birth observation is moved to the frame's time again with it in place of
  // the picture's.
  void MoveBirthObservation(size_t i, const cv::Point2f& px_per_s, int rows) {
    newborn[i] = 0;
    if (o.readout_ms <= 0) return;
    Observation& birth = tracks[ids[i]].back();
    const Eigen::Vector2d shown(at_kf[i].x, at_kf[i].y);
    birth.px = track::AtFrameTime(shown, {px_per_s.x, px_per_s.y}, 1e-3 * o.readout_ms, rows);
    birth.picture_offset_px = shown - birth.px;
  }
};

// Line segments at half resolution (a trunk edge is still a few pixels long there), kept when
// longer than segment_min_length and within a few degrees of the image vertical.
std::vector<cv::Vec4f> VerticalSegments(const FrontendOptions& o, const cv::Mat& gray,
                                        cv::LineSegmentDetector* lsd) {
  cv::Mat half;
  cv::resize(gray, half, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  std::vector<cv::Vec4f> lines, out;
  lsd->detect(half, lines);
  const double min_len = o.segment_min_length * half.rows;
  const double max_tan = std::tan(o.segment_max_tilt_deg * M_PI / 180.0);
  for (const cv::Vec4f& l : lines) {
    const double dx = l[2] - l[0], dy = l[3] - l[1];
    if (std::hypot(dx, dy) < min_len || std::abs(dx) > max_tan * std::abs(dy)) continue;
    // Back to working pixels (pixel centres at integers).
    out.emplace_back(2 * l[0] + 0.5f, 2 * l[1] + 0.5f, 2 * l[2] + 0.5f, 2 * l[3] + 0.5f);
  }
  return out;
}

// A keyframe's ORB features and vertical segments, found on a thread of their own: tracking needs
// neither, and they took a third of the tracking thread's time. Each keyframe is worked on alone
// and in turn, so the results do not depend on the timing. Any error is thrown by Finish().
class KeyframeFeatures {
 public:
  explicit KeyframeFeatures(const FrontendOptions& o)
      : o_(o),
        orb_(cv::ORB::create(o.orb_features)),
        lsd_(cv::createLineSegmentDetector(cv::LSD_REFINE_NONE)),
        worker_([this] { Work(); }) {}
  ~KeyframeFeatures() {  // on an error in tracking: the keyframes still waiting are dropped
    {
      std::lock_guard<std::mutex> lock(mutex_);
      jobs_.clear();
    }
    Stop();
  }

  // Finds keyframe `index`'s features on `gray` (shared, not copied: it must not change), its
  // segments moved to the frame's time with the picture's velocity `frame_vel` (px/s).
  void Add(size_t index, const cv::Mat& gray, const Eigen::Vector2d& frame_vel) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back({index, gray, frame_vel});
    }
    wake_.notify_one();
  }

  // Waits for every keyframe added and fills in their features.
  void Finish(std::vector<Keyframe>* keyframes) {
    Stop();
    if (error_) std::rethrow_exception(error_);
    for (Done& d : done_) {
      Keyframe& kf = (*keyframes)[d.index];
      kf.orb_keypoints = std::move(d.orb_keypoints);
      kf.orb_descriptors = d.orb_descriptors;
      kf.vertical_segments = std::move(d.vertical_segments);
    }
  }

 private:
  struct Job {
    size_t index;
    cv::Mat gray;
    Eigen::Vector2d frame_vel;
  };
  struct Done {
    size_t index;
    std::vector<cv::KeyPoint> orb_keypoints;
    cv::Mat orb_descriptors;
    std::vector<cv::Vec4f> vertical_segments;
  };

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    if (worker_.joinable()) worker_.join();
  }

  void Work() {
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
        if (jobs_.empty()) return;  // stopped, and every job done
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      if (error_) continue;  // after an error the rest is dropped
      try {
        done_.push_back(Find(job));
      } catch (...) {
        error_ = std::current_exception();
      }
    }
  }

  Done Find(const Job& job) {
    Done d{job.index, {}, {}, {}};
    orb_->detectAndCompute(job.gray, cv::noArray(), d.orb_keypoints, d.orb_descriptors);
    d.vertical_segments = VerticalSegments(o_, job.gray, lsd_.get());
    for (cv::Vec4f& l : d.vertical_segments) {
      for (int e : {0, 2}) {
        const Eigen::Vector2d at =
            AtFrameTime({l[e], l[e + 1]}, job.frame_vel, 1e-3 * o_.readout_ms, job.gray.rows);
        l[e] = static_cast<float>(at.x());
        l[e + 1] = static_cast<float>(at.y());
      }
    }
    return d;
  }

  const FrontendOptions& o_;
  cv::Ptr<cv::ORB> orb_;
  cv::Ptr<cv::LineSegmentDetector> lsd_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> jobs_;
  bool stop_ = false;
  // Touched by the worker alone until it is joined.
  std::vector<Done> done_;
  std::exception_ptr error_;
  std::thread worker_;  // last: starts once the members above exist
};

}  // namespace

FrontendResult RunFrontend(const FrontendOptions& o, VideoReader& reader,
                           const PinholeCamera& camera) {
  o.Check();
  FrontendResult r;
  r.info = reader.info();
  r.readout_s = 1e-3 * o.readout_ms;
  const int stride = FrameStride(r.info.fps, o.track_fps);
  const double step_rad = o.keyframe_step_deg * M_PI / 180.0;
  const cv::Size win(o.lk_window_px, o.lk_window_px);
  const cv::Size fine_win(o.lk_refine_window_px, o.lk_refine_window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);

  Tracker tr(o, camera);
  KeyframeFeatures features(o);
  std::vector<cv::Mat> prev_pyr, pyr;
  cv::Mat gray, bgr, gray_full;
  int64_t tracked_frames = 0;
  double tracked_sum = 0.0;
  Progress progress("tracking", std::max<int64_t>(1, r.info.frame_count));

  auto add_keyframe = [&](int frame, double t_s) {
    Keyframe kf;
    kf.frame = frame;
    kf.t_s = t_s;
    kf.picture_px_per_s = {tr.frame_vel.x, tr.frame_vel.y};
    kf.gray = gray.clone();  // `gray` is the next frame's buffer
    features.Add(r.keyframes.size(), kf.gray, {tr.frame_vel.x, tr.frame_vel.y});
    if (o.keep_keyframe_images) {
      kf.bgr = bgr;
      kf.gray_full = gray_full;
    }
    r.keyframes.push_back(std::move(kf));
    tr.Seed(gray);
    tr.RecordKeyframe(static_cast<int>(r.keyframes.size()) - 1, gray.rows);
  };

  int last_tracked = -1;
  int damaged_last = -1;
  double last_t = 0.0;
  while (std::optional<DecodedFrame> f = reader.Next()) {
    const int fi = static_cast<int>(r.frame_t_s.size());
    r.frame_t_s.push_back(f->t_s);
    progress.Update(fi + 1);
    if (fi % stride != 0) continue;
    if (f->damaged) {
      // A made-up picture would pull points along with it; the frames either side are bridged.
      ++r.damaged_frames;
      if (!r.damaged_spans_s.empty() && fi - damaged_last <= 2 * stride) {
        r.damaged_spans_s.back().second = f->t_s;
      } else {
        r.damaged_spans_s.emplace_back(f->t_s, f->t_s);
      }
      damaged_last = fi;
      continue;
    }
    if (!f->converted) {
      throw ProcessingError(fmt::format("frame {} was not converted for tracking", fi));
    }
    cv::cvtColor(f->bgr, gray, cv::COLOR_BGR2GRAY);
    if (r.working_size.empty()) r.working_size = gray.size();
    if (cv::mean(gray)[0] < o.dark_mean_luma) ++r.dark_frames;
    cv::buildOpticalFlowPyramid(gray, pyr, win, o.lk_levels);
    ++tracked_frames;
    last_tracked = fi;
    bgr = f->bgr;
    gray_full = f->gray_full;
    const double dt_s = f->t_s - last_t;
    if (prev_pyr.empty()) {
      add_keyframe(fi, f->t_s);
      std::swap(prev_pyr, pyr);
      last_t = f->t_s;
      continue;
    }
    std::vector<cv::Point2f> next, back;
    std::vector<uchar> st, st_back;
    std::vector<float> err;
    if (!tr.pts.empty()) {
      cv::calcOpticalFlowPyrLK(prev_pyr, pyr, tr.pts, next, st, err, win, o.lk_levels, term);
      // The small window places the point where it agrees with the large one; where it fails
      // (blur, little texture in it) the large window's place stands.
      std::vector<cv::Point2f> fine = next;
      std::vector<uchar> st_fine;
      cv::calcOpticalFlowPyrLK(prev_pyr, pyr, tr.pts, fine, st_fine, err, fine_win,
                               o.lk_refine_levels, term, cv::OPTFLOW_USE_INITIAL_FLOW);
      for (size_t i = 0; i < next.size(); ++i) {
        if (st[i] && st_fine[i] && cv::norm(fine[i] - next[i]) < o.lk_refine_max_shift_px) {
          next[i] = fine[i];
        }
      }
      back = tr.pts;
      cv::calcOpticalFlowPyrLK(pyr, prev_pyr, next, back, st_back, err, win, o.lk_levels, term,
                               cv::OPTFLOW_USE_INITIAL_FLOW);
    }
    std::vector<float> dx, dy;
    size_t k = 0;
    for (size_t i = 0; i < tr.pts.size(); ++i) {
      const cv::Point2f& p = next[i];
      const bool inside = p.x >= 2 && p.y >= 2 && p.x < gray.cols - 3 && p.y < gray.rows - 3;
      if (!st[i] || !st_back[i] || !inside ||
          cv::norm(back[i] - tr.pts[i]) > o.max_forward_backward_px) {
        continue;
      }
      dx.push_back(p.x - tr.pts[i].x);
      dy.push_back(p.y - tr.pts[i].y);
      if (dt_s > 0) {
        tr.vel[i] = (p - tr.pts[i]) * static_cast<float>(1.0 / dt_s);
        if (tr.newborn[i]) tr.MoveBirthObservation(i, tr.vel[i], gray.rows);
      }
      tr.pts[k] = p;
      tr.ids[k] = tr.ids[i];
      tr.at_kf[k] = tr.at_kf[i];
      tr.vel[k] = tr.vel[i];
      tr.newborn[k] = tr.newborn[i];
      ++k;
    }
    tr.pts.resize(k);
    tr.ids.resize(k);
    tr.at_kf.resize(k);
    tr.vel.resize(k);
    tr.newborn.resize(k);
    last_t = f->t_s;
    const float med_dx = Median(&dx), med_dy = Median(&dy);
    r.sideways_motion_px += std::abs(med_dx);
    r.vertical_motion_px += std::abs(med_dy);
    if (dt_s > 0) tr.frame_vel = cv::Point2f(med_dx, med_dy) * static_cast<float>(1.0 / dt_s);
    tracked_sum += k;
    std::swap(prev_pyr, pyr);

    size_t n_common = 0;
    const double rot = tr.RotationSinceKeyframe(&n_common);
    if (n_common < 15 && tr.alive_at_kf >= 15) {
      ++r.reseeds_for_loss;
      spdlog::debug("tracking: most points lost at t={:.2f} s", f->t_s);
    }
    if (std::abs(rot) >= step_rad || n_common < tr.alive_at_kf / 2 || n_common < 40) {
      add_keyframe(fi, f->t_s);
    } else {
      FrameObservations& b = r.between.emplace_back();
      b.frame = fi;
      b.t_s = f->t_s;
      b.track = tr.ids;
      b.px.reserve(tr.pts.size());
      for (size_t i = 0; i < tr.pts.size(); ++i) {
        b.px.push_back(tr.AtFrameTime(i, gray.rows).cast<float>());
      }
    }
  }
  progress.Finish();
  if (r.frame_t_s.empty()) throw InputError("the video has no decodable frame");
  // The last tracked frame closes the sequence as a keyframe so the trajectory covers it.
  if (last_tracked >= 0 && r.keyframes.back().frame != last_tracked) {
    add_keyframe(last_tracked, last_t);
  }
  features.Finish(&r.keyframes);
  r.corrupt_packets = reader.corrupt_packets();
  AddMissingSpans(r.info.fps, r.frame_t_s, &r.damaged_spans_s);
  r.tracked_frames = static_cast<int>(tracked_frames);
  r.mean_tracked_points = tracked_frames > 1 ? tracked_sum / (tracked_frames - 1) : 0.0;
  std::vector<int> kept(tr.tracks.size(), -1);
  for (size_t t = 0; t < tr.tracks.size(); ++t) {
    if (tr.tracks[t].size() < 2) continue;
    kept[t] = static_cast<int>(r.tracks.size());
    r.tracks.push_back({std::move(tr.tracks[t])});
  }
  for (FrameObservations& b : r.between) {
    size_t k = 0;
    for (size_t i = 0; i < b.track.size(); ++i) {
      if (kept[b.track[i]] < 0) continue;
      b.track[k] = kept[b.track[i]];
      b.px[k++] = b.px[i];
    }
    b.track.resize(k);
    b.px.resize(k);
  }
  // The last tracked frame may have become a keyframe after it was recorded here.
  while (!r.between.empty() && r.between.back().frame >= r.keyframes.back().frame) {
    r.between.pop_back();
  }
  return r;
}

}  // namespace stemmap::track
