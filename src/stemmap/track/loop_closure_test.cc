#include "stemmap/track/loop_closure.h"

#include <gtest/gtest.h>

namespace stemmap::track {
namespace {

// Two keyframes one turn apart under a rolling shutter: a track seen early, another seen late
// whose top-row observation was moved 9 px to the frame's time. The loop's ORB keypoints are
// found where the pictures show the points.
FrontendResult RevisitUnderARollingShutter() {
  FrontendResult f;
  f.working_size = cv::Size(320, 240);
  f.readout_s = 0.06;
  f.keyframes.resize(2);
  // Moving left at 300 px/s, the top row read 30 ms early shows a point 9 px right of where it
  // was at the frame's time.
  f.keyframes[1].picture_px_per_s = {-300.0, 0.0};
  const Eigen::Vector2d shift(9.0, 0.0);
  f.tracks = {{{{0, {50.0, 120.0}}}}, {{{1, Eigen::Vector2d(100.0, 0.0) - shift, shift}}}};
  return f;
}

TEST(MergeLoopTracks, KeypointsMeetTheTracksWhereThePicturesShowThem) {
  FrontendResult f = RevisitUnderARollingShutter();
  LoopResult loop;
  loop.pairs.push_back(
      {0, 1, 1, 0.0, {{Eigen::Vector2d(50.0, 120.0), Eigen::Vector2d(100.0, 0.0)}}});
  MergeLoopTracks(LoopOptions{}, f, loop);
  EXPECT_EQ(loop.merged_tracks, 1);
  EXPECT_EQ(loop.extended_tracks, 0);
  ASSERT_EQ(f.tracks.size(), 1u);
  ASSERT_EQ(f.tracks[0].obs.size(), 2u);
}

TEST(MergeLoopTracks, AnExtendingKeypointIsMovedToTheFramesTime) {
  FrontendResult f = RevisitUnderARollingShutter();
  f.tracks.pop_back();  // nothing tracked at the revisit
  LoopResult loop;
  loop.pairs.push_back(
      {0, 1, 1, 0.0, {{Eigen::Vector2d(50.0, 120.0), Eigen::Vector2d(100.0, 0.0)}}});
  MergeLoopTracks(LoopOptions{}, f, loop);
  EXPECT_EQ(loop.extended_tracks, 1);
  ASSERT_EQ(f.tracks.size(), 1u);
  ASSERT_EQ(f.tracks[0].obs.size(), 2u);
  const Observation& late = f.tracks[0].obs[1];
  EXPECT_NEAR(late.px.x(), 91.0, 1e-9);
  EXPECT_NEAR(late.px.y(), 0.0, 1e-9);
  EXPECT_NEAR(late.picture_offset_px.x(), 9.0, 1e-9);
}

}  // namespace
}  // namespace stemmap::track
