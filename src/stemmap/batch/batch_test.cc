#include "stemmap/batch/batch.h"

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::batch {
namespace {

namespace fs = std::filesystem;

fs::path BatchDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("stemmap_batch_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

const char* kHeader =
    "plot_id,video,arm_radius_m,hfov_deg,calibration,camera_height_m,vertical,plot_centre,"
    "first_bearing_deg\n";

TEST(ReadManifest, EmptyCellsTakeTheDefaultsAndPathsAreTheManifests) {
  const fs::path dir = BatchDir("manifest");
  WriteFileAtomic(dir / "m.csv", std::string(kHeader) +
                                     "p1,videos/p1.mp4,,,,,,,\n"
                                     "p2,p2.mov,1.2,70,phone.yaml,1.31,axis,42.31 -2.52,212\n");
  pipeline::ProcessOptions defaults;
  defaults.track.arm_radius_m = 0.9;
  const std::vector<PlotRow> rows = ReadManifest(dir / "m.csv", defaults);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].video, dir / "videos/p1.mp4");
  EXPECT_EQ(rows[0].options.track.arm_radius_m, 0.9);
  EXPECT_FALSE(rows[0].options.georef.HasCentre());
  EXPECT_EQ(rows[1].options.track.arm_radius_m, 1.2);
  EXPECT_EQ(rows[1].options.track.hfov_deg, 70.0);
  EXPECT_EQ(rows[1].options.track.calibration, dir / "phone.yaml");
  EXPECT_EQ(rows[1].options.track.camera_height_m, 1.31);
  EXPECT_EQ(rows[0].options.track.vertical_from, track::VerticalSource::kTrunks);
  EXPECT_EQ(rows[1].options.track.vertical_from, track::VerticalSource::kAxis);
  EXPECT_EQ(rows[1].options.georef.centre_lat_deg.value(), 42.31);
  EXPECT_EQ(rows[1].options.georef.centre_lon_deg.value(), -2.52);
  EXPECT_EQ(rows[1].options.georef.first_bearing_deg.value(), 212.0);
}

TEST(ReadManifest, SaysWhichLineIsWrong) {
  const fs::path dir = BatchDir("bad_manifest");
  auto refused = [&](const std::string& body, const std::string& expected) {
    WriteFileAtomic(dir / "m.csv", body);
    try {
      ReadManifest(dir / "m.csv", {});
      ADD_FAILURE() << "accepted: " << body;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused(std::string(kHeader) + "p1,a.mp4,,,,,,,\np1,b.mp4,,,,,,,\n", "line 3: plot_id 'p1'");
  refused(std::string(kHeader) + "../up,a.mp4,,,,,,,\n", "line 2: plot_id '../up'");
  refused(std::string(kHeader) + "p1,a.mp4,,,,,,42.3,\n", "line 2: plot_centre must be `LAT LON`");
  refused(std::string(kHeader) + "p1,a.mp4,one,,,,,,\n", "line 2: column arm_radius_m");
  refused(std::string(kHeader) + "p1,a.mp4,,,,,level,,\n",
          "line 2: vertical 'level' is not trunks or axis");
  refused(std::string(kHeader) + "p1,a.mp4,,,,,,42.3 -2.5,\n", "line 2: a plot centre needs");
  refused("plot_id,video,speed\np1,a.mp4,3\n", "unknown column 'speed'");
  refused(std::string(kHeader), "lists no plot");
}

// A finished plot as `process` leaves it, with a centre so that it joins the GeoPackage.
void WriteFinishedPlot(const fs::path& dir) {
  WriteJsonAtomic(dir / "stemmap_run.json", {{"command", "process"}});
  WriteJsonAtomic(
      dir / "summary.json",
      {{"plot",
        {{"stems", 2}, {"stems_per_ha", 63.7}, {"basal_area_m2_per_ha", 3.1}, {"qmd_cm", 24.9}}}});
  WriteFileAtomic(dir / "trees.csv",
                  "tree_id,x_m,y_m,dbh_cm,dbh_sd_cm,lat,lon\n"
                  "1,1,2,30.1,0.8,42.31001,-2.52002\n2,-3,1,18.2,0.6,42.30998,-2.52004\n");
}

TEST(RunBatch, GoesOnPastAFailedPlotAndRedoesNoFinishedOne) {
  const fs::path dir = BatchDir("run");
  WriteFileAtomic(dir / "m.csv", std::string(kHeader) +
                                     "done,done.mp4,,,,,,42.31 -2.52,10\n"
                                     "missing,nowhere.mp4,,,,,,,\n"
                                     "also_missing,gone.mp4,,,,,,,\n");
  WriteFinishedPlot(dir / "out" / "done");
  const BatchSummary s = RunBatch({}, dir / "m.csv", dir / "out");
  EXPECT_EQ(s.finished, 1);
  EXPECT_EQ(s.failed, 2);
  EXPECT_EQ(s.ran_now, 2);  // the finished plot was not run again
  EXPECT_FALSE(s.plots[0].ran_now);
  EXPECT_NE(s.plots[1].message.find("nowhere.mp4"), std::string::npos) << s.plots[1].message;
  const nlohmann::json failed = ReadJsonFile(dir / "out" / "missing.failed.json");
  EXPECT_EQ(failed["plot_id"], "missing");
  const std::string table = ReadFileToString(dir / "out" / "batch_summary.csv");
  EXPECT_NE(table.find("done,finished,2,63.7,3.100,24.9,42.3100000,-2.5200000,"), std::string::npos)
      << table;
  EXPECT_NE(table.find("missing,failed,"), std::string::npos);
  GDALAllRegister();
  GDALDataset* gpkg = GDALDataset::Open((dir / "out" / "plots.gpkg").c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(gpkg, nullptr);
  EXPECT_EQ(gpkg->GetLayerByName("plots")->GetFeatureCount(), 1);
  EXPECT_EQ(gpkg->GetLayerByName("trees")->GetFeatureCount(), 2);
  GDALClose(gpkg);
  // One task of a job array runs its own row only, and writes no summary.
  BatchOptions one;
  one.task = 3;
  fs::remove(dir / "out" / "batch_summary.csv");
  const BatchSummary t = RunBatch(one, dir / "m.csv", dir / "out");
  EXPECT_EQ(t.ran_now, 1);
  EXPECT_FALSE(t.plots[1].ran_now);
  EXPECT_FALSE(fs::exists(dir / "out" / "batch_summary.csv"));
  one.task = 4;
  EXPECT_THROW(RunBatch(one, dir / "m.csv", dir / "out"), InputError);
}

}  // namespace
}  // namespace stemmap::batch
