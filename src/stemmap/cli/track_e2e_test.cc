// End to end: simulate short captures and track them; bad videos fail with a clear error.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "stemmap/cli/test_renders.h"
#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/pose.h"
#include "stemmap/dense/cloud_io.h"
#include "stemmap/eval/evaluate.h"
#include "stemmap/eval/plot_io.h"
#include "stemmap/gis/las.h"
#include "stemmap/pipeline/process.h"
#include "stemmap/sim/simulate.h"
#include "stemmap/track/track.h"
#include "stemmap/video/video_writer.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

fs::path TestDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("stemmap_track_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

sim::SimulateOptions ShortPlot(const fs::path& dir, double turns) {
  sim::SimulateOptions o;
  o.seed = 4;
  o.kind = sim::StandKind::kManaged;
  o.out_dir = dir;
  o.width = 480;
  o.height = 270;
  o.fps = 10;
  o.seconds = 9;
  o.turns = turns;
  o.stills = 0;
  return o;
}

// The simulated camera, as a user would pass their calibration.
track::TrackOptions OptionsFromTruth(const fs::path& truth_json) {
  const nlohmann::json t = ReadJsonFile(truth_json);
  track::TrackOptions o;
  o.arm_radius_m = t["arm_radius_m"];
  o.hfov_deg = t["intrinsics"]["hfov_deg"];
  o.camera_height_m = t["camera_height_m"];
  return o;
}

TEST(TrackEndToEnd, RecoversTheSimulatedTrajectory) {
  const fs::path dir = TestDir("ok");
  sim::RunSimulate(ShortPlot(dir, 1.1));
  const track::TrackOptions o = OptionsFromTruth(dir / "truth.json");
  const track::TrackResult r = track::RunTrack(o, dir / "video.mp4", dir / "track");
  for (const char* f :
       {"trajectory.tum", "keyframes.tum", "sparse.ply", "summary.json", "track_options.json"}) {
    EXPECT_TRUE(fs::exists(dir / "track" / f)) << f;
  }
  EXPECT_EQ(r.frames.size(), 90u);
  EXPECT_TRUE(r.summary["loop_closed"].get<bool>());
  // 1.1 turns over 9 s; the last frame is at 8.9 s.
  EXPECT_NEAR(r.summary["turn_deg"].get<double>(), 396.0 * 89 / 90, 3.0);

  const eval::TruthPlot truth = eval::ReadTruthJson(dir / "truth.json");
  const eval::TrajectoryStats s = eval::CompareTrajectories(truth.poses, r.frames);
  EXPECT_EQ(s.n_poses, 90);
  EXPECT_LT(s.ate_rmse_m, 0.04);  // a 480x270 clip at 10 fps; the benchmark uses 1080p
  EXPECT_LT(std::abs(s.scale_error_pct), 1.0);
  EXPECT_LT(s.mean_rotation_error_deg, 2.5);  // mostly the vertical: few trunk edges at this size

  // Same input, same output.
  track::RunTrack(o, dir / "video.mp4", dir / "again");
  EXPECT_EQ(ReadFileToString(dir / "track" / "trajectory.tum"),
            ReadFileToString(dir / "again" / "trajectory.tum"));
  fs::remove_all(dir);
}

// Some phones record slowly and users subsample: 4 fps must track too.
TEST(TrackEndToEnd, LowFrameRate) {
  const fs::path dir = TestDir("lowfps");
  sim::SimulateOptions so = ShortPlot(dir, 1.1);
  so.fps = 4;
  so.seconds = 24;
  sim::RunSimulate(so);
  const track::TrackResult r =
      track::RunTrack(OptionsFromTruth(dir / "truth.json"), dir / "video.mp4", dir / "track");
  EXPECT_TRUE(r.summary["loop_closed"].get<bool>());
  const eval::TrajectoryStats s =
      eval::CompareTrajectories(eval::ReadTruthJson(dir / "truth.json").poses, r.frames);
  EXPECT_EQ(s.n_poses, 96);
  EXPECT_LT(s.ate_rmse_m, 0.06);
  EXPECT_LT(std::abs(s.scale_error_pct), 1.0);
  fs::remove_all(dir);
}

// The angle between the plot frame's "up" and the truth's, over the whole track: the mean over
// frames of the truth's up seen through each estimated pose (each frame's own orientation noise
// averages out; the frame's tilt does not).
double PlotTiltDeg(const std::vector<StampedPose>& truth, const std::vector<StampedPose>& frames) {
  EXPECT_EQ(truth.size(), frames.size());
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < std::min(truth.size(), frames.size()); ++i) {
    up += truth[i].world_from_cam.rotation *
          (frames[i].world_from_cam.rotation.conjugate() * Eigen::Vector3d::UnitZ());
  }
  return std::acos(std::clamp(up.normalized().z(), -1.0, 1.0)) * 180.0 / M_PI;
}

// A tripod levelled with its bubble: the arm's axis is the vertical, where the trunks' edges
// (few at this size, and trees lean) put it further off; on a tilted tripod the axis is not.
TEST(TrackEndToEnd, ALevelledTripodsAxisIsTheVertical) {
  const fs::path dir = TestDir("levelled");
  for (const double tilt_deg : {0.0, 1.5}) {
    sim::SimulateOptions so = ShortPlot(dir, 1.1);
    so.stand_tilt_deg = tilt_deg;
    sim::RunSimulate(so);
    const eval::TruthPlot truth = eval::ReadTruthJson(dir / "truth.json");
    track::TrackOptions o = OptionsFromTruth(dir / "truth.json");
    const auto tilt_from = [&](track::VerticalSource from) {
      o.vertical_from = from;
      const track::TrackResult r = track::RunTrack(o, dir / "video.mp4", dir / "track");
      EXPECT_EQ(r.summary["vertical_from"], track::VerticalSourceName(from));
      return PlotTiltDeg(truth.poses, r.frames);
    };
    const double from_axis_deg = tilt_from(track::VerticalSource::kAxis);
    EXPECT_NEAR(from_axis_deg, tilt_deg, 0.1) << tilt_deg;
    if (tilt_deg == 0) {
      EXPECT_GT(tilt_from(track::VerticalSource::kTrunks), 0.2);
    }
    fs::remove_all(dir);
  }
}

TEST(ProcessEndToEnd, ShortPlotGivesATreeList) {
  const fs::path dir = TestDir("process");
  sim::SimulateOptions so = ShortPlot(dir / "plot", 1.1);
  so.width = 640;
  so.height = 360;
  const fs::path plot = RenderedOnce(SharedRenders(dir), "process_640", std::to_string(::getpid()),
                                     [&](const fs::path& folder) {
                                       so.out_dir = folder;
                                       sim::RunSimulate(so);
                                     });
  pipeline::ProcessOptions o;
  o.track = OptionsFromTruth(plot / "truth.json");
  // Focal lengths per keyframe kept whatever they are, as for a focus that breathes: the
  // keyframes' pictures are redrawn at the shared one, and the runs below from the saved track
  // must redraw them the same way to find the same trees.
  o.track.breathing_min_pct = 0.0;
  o.track.breathing_min_keyframes = 1;
  o.georef.centre_easting_m = 545000.0;
  o.georef.centre_northing_m = 4700000.0;
  o.georef.crs = "EPSG:25830";
  o.georef.first_bearing_deg = 212.0;
  const pipeline::ProcessResult r = pipeline::RunProcess(o, plot / "video.mp4", dir / "out");
  for (const char* f : {"trees.csv", "summary.json", "cloud.ply", "stems_detail.csv",
                        "trajectory.tum", "process_options.json", "map.svg", "report.html",
                        "trees.gpkg", "trees.geojson", "cloud.las"}) {
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  }
  // The cloud as LAS holds every point of cloud.ply, placed on the map.
  const gis::LasFile las = gis::ReadLas(dir / "out" / "cloud.las");
  const std::vector<dense::CloudPoint> cloud = dense::ReadCloudPly(dir / "out" / "cloud.ply");
  ASSERT_EQ(las.points.size(), cloud.size());
  ASSERT_FALSE(cloud.empty());
  const Eigen::Vector2d en = gis::EastNorth(212.0, 0.0, cloud[0].world.head<2>().cast<double>());
  EXPECT_NEAR(las.points[0].xyz.x(), 545000.0 + en.x(), 0.001);
  EXPECT_NEAR(las.points[0].xyz.y(), 4700000.0 + en.y(), 0.001);
  // The report shows every tree in a keyframe (the track saw each of them).
  ASSERT_FALSE(r.stems.empty());
  for (size_t i = 1; i <= r.stems.size(); ++i) {
    EXPECT_TRUE(fs::exists(dir / "out" / "report" / fmt::format("tree_{:03d}.jpg", i))) << i;
  }
  const nlohmann::json summary = ReadJsonFile(dir / "out" / "summary.json");
  EXPECT_EQ(summary["plot"]["stems"].get<int>(), r.figures.stems);
  EXPECT_TRUE(summary["track"]["breathing_corrected"].get<bool>());
  EXPECT_GT(r.figures.basal_area_m2_per_ha, 0.0);
  // The resolved options sit beside the outputs, the silhouette search's included.
  const nlohmann::json saved = ReadJsonFile(dir / "out" / "process_options.json");
  EXPECT_EQ(saved["measure"]["tangent"]["sideways_start_shifts"].get<std::vector<double>>(),
            o.measure.tangent.sideways_start_shifts);
  EXPECT_EQ(saved["measure"]["stems"]["breast_height_m"].get<double>(),
            o.measure.stems.breast_height_m);
  for (const stems::Stem& s : r.stems) EXPECT_GE(100 * s.dbh_m, o.measure.min_dbh_cm);
  // tree_id counts outward from the centre.
  for (size_t i = 1; i < r.stems.size(); ++i) {
    EXPECT_LE(r.stems[i - 1].centre_xy.norm(), r.stems[i].centre_xy.norm()) << i;
  }
  // A short, small clip: most near trees found, none far off.
  eval::EvaluateOptions eo;
  eo.plot_radius_m = 8.0;
  const eval::TruthPlot truth = eval::ReadTruthJson(plot / "truth.json");
  const eval::MatchStats m =
      eval::MatchAndScore(eo, truth.trees, eval::ReadTreesCsv(dir / "out" / "trees.csv"));
  EXPECT_GE(m.recall, 0.6);
  EXPECT_GE(m.precision, 0.6);
  EXPECT_LT(m.dbh.mae_cm, 8.0);

  // The later stages again on the saved track: the same trees, without tracking.
  pipeline::ProcessOptions again = o;
  again.from_track = dir / "out";
  const pipeline::ProcessResult r2 = pipeline::RunProcess(again, plot / "video.mp4", dir / "again");
  ASSERT_EQ(r2.stems.size(), r.stems.size());
  for (size_t i = 0; i < r.stems.size(); ++i) {
    EXPECT_NEAR((r2.stems[i].centre_xy - r.stems[i].centre_xy).norm(), 0.0, 1e-3) << i;
    EXPECT_NEAR(r2.stems[i].dbh_m, r.stems[i].dbh_m, 1e-3) << i;
  }
  EXPECT_TRUE(fs::exists(dir / "again" / "trajectory.tum"));
  EXPECT_EQ(ReadJsonFile(dir / "again" / "summary.json")["track"]["reused_from"],
            fs::absolute(dir / "out").string());
  // Detection alone again from the process run's folder: the same trees.
  const pipeline::ProcessResult r3 =
      pipeline::RunStems(o, plot / "video.mp4", dir / "out", dir / "stems");
  ASSERT_EQ(r3.stems.size(), r.stems.size());
  for (size_t i = 0; i < r.stems.size(); ++i) {
    EXPECT_NEAR((r3.stems[i].centre_xy - r.stems[i].centre_xy).norm(), 0.0, 1e-6) << i;
    EXPECT_NEAR(r3.stems[i].dbh_m, r.stems[i].dbh_m, 1e-6) << i;
  }
  for (const char* f : {"trees.csv", "summary.json", "process_options.json", "cloud.ply",
                        "cloud_coarse.ply", "keyframes.tum"}) {
    EXPECT_TRUE(fs::exists(dir / "stems" / f)) << f;
  }
  // A track without a cloud is no folder to detect from.
  fs::create_directories(dir / "track_only");
  for (const char* f : {"keyframes.tum", "summary.json"}) {
    fs::copy_file(dir / "out" / f, dir / "track_only" / f);
  }
  EXPECT_THROW(pipeline::RunStems(o, plot / "video.mp4", dir / "track_only", dir / "bad"),
               InputError);
  // A folder that holds no track, or a video of another size, is refused.
  pipeline::ProcessOptions bad = o;
  bad.from_track = dir / "again" / "missing";
  EXPECT_THROW(pipeline::RunProcess(bad, plot / "video.mp4", dir / "bad"), InputError);
  sim::SimulateOptions small = ShortPlot(dir / "small", 1.1);
  small.seconds = 1;
  sim::RunSimulate(small);
  EXPECT_THROW(pipeline::RunProcess(again, dir / "small" / "video.mp4", dir / "bad"), InputError);
  fs::remove_all(dir);
}

TEST(TrackEndToEnd, HalfATurnIsNotAPlot) {
  const fs::path dir = TestDir("half");
  sim::SimulateOptions so = ShortPlot(dir, 0.6);
  so.seconds = 5;
  sim::RunSimulate(so);
  try {
    track::RunTrack(OptionsFromTruth(dir / "truth.json"), dir / "video.mp4", dir / "track");
    FAIL() << "a half turn was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("full turn"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "track" / "trajectory.tum"));
  fs::remove_all(dir);
}

TEST(TrackEndToEnd, DarkShortAndCorruptVideosAreRejected) {
  const fs::path dir = TestDir("bad");
  fs::create_directories(dir);
  VideoWriterOptions wo;
  wo.width = 320;
  wo.height = 180;
  wo.fps = 10;
  {
    VideoWriter w(dir / "dark.mp4", wo);
    for (int i = 0; i < 30; ++i) w.Write(cv::Mat(180, 320, CV_8UC3, cv::Scalar(3, 3, 3)));
    w.Close();
  }
  track::TrackOptions o;
  try {
    track::RunTrack(o, dir / "dark.mp4", dir / "out");
    FAIL() << "a black video was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dark"), std::string::npos) << e.what();
  }
  {
    VideoWriter w(dir / "short.mp4", wo);
    for (int i = 0; i < 2; ++i) w.Write(cv::Mat(180, 320, CV_8UC3, cv::Scalar(90, 120, 60)));
    w.Close();
  }
  try {
    track::RunTrack(o, dir / "short.mp4", dir / "out");
    FAIL() << "a two-frame video was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("too short"), std::string::npos) << e.what();
  }
  WriteFileAtomic(dir / "junk.mp4", std::string(5000, 'x'));
  EXPECT_THROW(track::RunTrack(o, dir / "junk.mp4", dir / "out"), InputError);
  EXPECT_THROW(track::RunTrack(o, dir / "missing.mp4", dir / "out"), InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace stemmap
