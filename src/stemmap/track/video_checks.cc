#include "stemmap/track/video_checks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"

namespace stemmap::track {

namespace {

// The smallest video that holds a plot's trunks at a measurable width (px, long and short side).
constexpr int kMinLongSidePx = 320;
constexpr int kMinShortSidePx = 180;

}  // namespace

void CheckFrameSize(const VideoInfo& info) {
  const int long_side = std::max(info.full_width, info.full_height);
  const int short_side = std::min(info.full_width, info.full_height);
  if (long_side < kMinLongSidePx || short_side < kMinShortSidePx) {
    throw InputError(fmt::format(
        "the video is {}x{} px, too small to measure trunks in (at least {}x{} is needed; record "
        "at 1080p)",
        info.full_width, info.full_height, kMinLongSidePx, kMinShortSidePx));
  }
}

// Why the picture's motion cannot be a turn of the arm; empty when it can. A full turn moves the
// picture sideways by about 360°/HFOV frame widths.
std::string MotionProblem(const FrontendResult& f, const PinholeCamera& camera) {
  const double w = f.working_size.width, h = f.working_size.height;
  const double seconds = f.frame_t_s.back() - f.frame_t_s.front();
  if (f.sideways_motion_px < 0.25 * w && f.vertical_motion_px < 0.25 * h) {
    return fmt::format(
        "the camera does not turn: in {:.0f} s the picture moved {:.0f} px sideways, where one "
        "turn of the arm moves it some {:.0f} frame widths; push the arm round one full turn "
        "while recording",
        seconds, f.sideways_motion_px, 360.0 / camera.HfovDeg());
  }
  if (f.vertical_motion_px > 2.0 * f.sideways_motion_px) {
    return "the picture moves up and down, not sideways: the video is turned 90° (a rotation "
           "tag lost?); turn it upright first, e.g. `ffmpeg -i IN -vf transpose=1 OUT` "
           "(transpose=2 turns the other way), or record in landscape";
  }
  return {};
}

// Whether the frames end well before the time the file's header gives (a copy cut short).
bool EndsEarly(const FrontendResult& f) {
  const double header_s = f.info.duration_s;
  return header_s > 0 && f.frame_t_s.back() < header_s - std::max(1.0, 0.05 * header_s);
}

// What the file itself lacks, to add to a failure's message: the part a cut-short copy lost,
// and where the decoder met damaged data. Empty for a whole, clean file.
std::string DamageNote(const FrontendResult& f) {
  std::string note;
  if (EndsEarly(f)) {
    note += fmt::format(
        "; the file is incomplete: frames up to {:.1f} s of the {:.1f} s its header gives could "
        "be read (a copy cut short?)",
        f.frame_t_s.back(), f.info.duration_s);
  }
  if (f.damaged_frames > 0 || f.corrupt_packets > 0) {
    note += fmt::format("; the file is damaged: {} frames could not be decoded whole",
                        f.damaged_frames + f.corrupt_packets);
    for (size_t i = 0; i < std::min<size_t>(3, f.damaged_spans_s.size()); ++i) {
      note += fmt::format("{} {:.1f}-{:.1f} s", i == 0 ? ", at" : ",", f.damaged_spans_s[i].first,
                          f.damaged_spans_s[i].second);
    }
  }
  return note;
}

// Fills the turn increments lost (NaN) where damaged or missing frames broke the tracks between
// two keyframes at most `max_gap_s` apart, with the median turn rate of the tracked increments
// nearby times the time between them. Returns the bridged stretches (s).
std::vector<std::pair<double, double>> BridgeDamagedGaps(const FrontendResult& f, double max_gap_s,
                                                         std::vector<double>* inc) {
  std::vector<std::pair<double, double>> bridged;
  const auto damaged_between = [&f](double t0, double t1) {
    return std::any_of(f.damaged_spans_s.begin(), f.damaged_spans_s.end(),
                       [&](const auto& s) { return s.first <= t1 && s.second >= t0; });
  };
  constexpr int kRateWindow = 6;  // keyframes either side whose turn rate is used
  for (size_t k = 1; k < inc->size(); ++k) {
    const double t0 = f.keyframes[k - 1].t_s, t1 = f.keyframes[k].t_s;
    if (!std::isnan((*inc)[k]) || t1 - t0 > max_gap_s || !damaged_between(t0, t1)) continue;
    std::vector<double> rates;
    for (size_t j = k > kRateWindow ? k - kRateWindow : 1;
         j < std::min(inc->size(), k + kRateWindow + 1); ++j) {
      const double dt = f.keyframes[j].t_s - f.keyframes[j - 1].t_s;
      if (j != k && !std::isnan((*inc)[j]) && dt > 0) rates.push_back((*inc)[j] / dt);
    }
    if (rates.empty()) continue;
    std::nth_element(rates.begin(), rates.begin() + rates.size() / 2, rates.end());
    (*inc)[k] = rates[rates.size() / 2] * (t1 - t0);
    bridged.emplace_back(t0, t1);
  }
  return bridged;
}

}  // namespace stemmap::track
