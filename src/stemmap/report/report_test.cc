#include "stemmap/report/report.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "stemmap/core/io.h"

namespace stemmap::report {
namespace {

// A camera on the arm's circle at azimuth `az_deg`, 1.3 m up, looking outward.
Rigid3d OutwardPose(double az_deg) {
  const double th = az_deg * M_PI / 180.0;
  Eigen::Matrix3d rot;  // columns: camera x (right), y (down), z (forward) in the plot frame
  rot << std::sin(th), 0, std::cos(th), -std::cos(th), 0, std::sin(th), 0, -1, 0;
  return {Eigen::Quaterniond(rot), Eigen::Vector3d(std::cos(th), std::sin(th), 1.3)};
}

stems::Stem StemAt(double x, double y, double dbh_m) {
  stems::Stem s;
  s.centre_xy = {x, y};
  s.dbh_m = dbh_m;
  s.ground_z_m = s.floor_z_m = 1.3 - 1.37;  // breast height level with the camera
  return s;
}

const PinholeCamera kCamera = PinholeCamera::FromHfov(640, 360, 60.0);

TEST(ProjectSilhouette, EdgesOfAStemStraightAheadAreSymmetric) {
  const auto e = ProjectSilhouette(kCamera, OutwardPose(0.0), {6.0, 0.0}, 0.15, 1.3);
  ASSERT_TRUE(e.has_value());
  // Seen from 5 m, the edges lie at ±asin(r/d) off the axis.
  const double half_px = kCamera.fx * std::tan(std::asin(0.15 / 5.0));
  EXPECT_NEAR(e->left.x(), kCamera.cx - half_px, 1e-6);
  EXPECT_NEAR(e->right.x(), kCamera.cx + half_px, 1e-6);
  EXPECT_NEAR(e->left.y(), kCamera.cy, 1e-6);
}

TEST(ProjectSilhouette, NothingForAStemBehindOrAroundTheCamera) {
  EXPECT_FALSE(ProjectSilhouette(kCamera, OutwardPose(0.0), {-4.0, 0.0}, 0.15, 1.3));
  EXPECT_FALSE(ProjectSilhouette(kCamera, OutwardPose(0.0), {1.05, 0.0}, 0.15, 1.3));
  EXPECT_FALSE(ProjectSilhouette(kCamera, OutwardPose(0.0), {6.0, 0.0}, 0.0, 1.3));
}

TEST(BestView, PrefersAClearViewToACentredButHiddenOne) {
  // Stem 1 at 6 m on +x; stem 0, nearer and a little to the right, covers part of it seen from
  // the arm at 0°, not from the arm at 20°, where stem 1 is 24° off-centre.
  const std::vector<stems::Stem> stems = {StemAt(3.0, -0.2, 0.3), StemAt(6.0, 0.0, 0.3)};
  const std::vector<StampedPose> keyframes = {{0.0, OutwardPose(0.0)}, {1.0, OutwardPose(20.0)}};
  EXPECT_EQ(BestView(kCamera, keyframes, stems, 1, 1.37), 1);
  EXPECT_EQ(BestView(kCamera, keyframes, stems, 0, 1.37), 0);
  // A stem no keyframe sees.
  const std::vector<stems::Stem> behind = {StemAt(-6.0, 0.0, 0.3)};
  EXPECT_EQ(BestView(kCamera, keyframes, behind, 0, 1.37), -1);
}

TEST(WriteReport, ShowsEachTreeWithTicksOnItsEdges) {
  const std::vector<stems::Stem> stems = {StemAt(6.0, 0.0, 0.3)};
  const std::vector<StampedPose> keyframes = {{0.0, OutwardPose(0.0)}};
  // A dark trunk exactly as wide as the stem, on a bright background.
  const auto edges = ProjectSilhouette(kCamera, OutwardPose(0.0), {6.0, 0.0}, 0.15, 1.3);
  ASSERT_TRUE(edges.has_value());
  cv::Mat image(kCamera.height, kCamera.width, CV_8UC3, cv::Scalar(200, 200, 200));
  image
      .colRange(static_cast<int>(std::lround(edges->left.x())),
                static_cast<int>(std::lround(edges->right.x())))
      .setTo(cv::Scalar(40, 50, 60));
  const std::vector<cv::Mat> images = {image};
  ReportInput in;
  in.stems = &stems;
  in.camera = &kCamera;
  in.keyframes = &keyframes;
  in.images = &images;
  in.title = "plot <A>";
  in.figures = {{"stems/ha", "32"}};
  in.metadata = {{"arm radius", "1.00 m"}};
  in.stand_table = {{25.0, 30.0, 1, 31.8, 1.9}};
  const auto dir = std::filesystem::path(::testing::TempDir()) / "stemmap_report_test";
  std::filesystem::remove_all(dir);
  ReportOptions o;
  const ReportSummary s = WriteReport(o, in, dir);
  EXPECT_EQ(s.thumbnails, 1);
  const std::string html = ReadFileToString(dir / "report.html");
  EXPECT_NE(html.find("<title>plot &lt;A&gt;</title>"), std::string::npos);
  // The crop shows small and opens full size, labelled with its time in the video.
  EXPECT_NE(html.find("<a href=\"report/tree_001.jpg\"><img src=\"report/tree_001.jpg\" "
                      "height=\"180\""),
            std::string::npos);
  EXPECT_NE(html.find("video 0.0 s"), std::string::npos);
  // The run, the stand table with its histogram, every flag in words, and a page for print.
  EXPECT_NE(html.find("<th>arm radius</th><td>1.00 m</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>25-30</td><td>1</td><td>32</td><td>1.90</td>"), std::string::npos);
  EXPECT_NE(html.find("<dt>silhouette_only</dt>"), std::string::npos);
  EXPECT_NE(html.find("@page { size: A4"), std::string::npos);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  // The map's stem links to its row.
  EXPECT_NE(html.find("<a href=\"#tree-1\">"), std::string::npos);
  EXPECT_NE(html.find("<tr id=\"tree-1\">"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir / "map.svg"));
  const cv::Mat thumb = cv::imread((dir / "report/tree_001.jpg").string());
  ASSERT_FALSE(thumb.empty());
  EXPECT_EQ(thumb.rows, o.crop_height_px);
  // The green ticks sit on the trunk's two edges: the greenest columns lie symmetric about the
  // thumbnail's middle, one trunk width apart (in thumbnail pixels).
  const double scale =
      thumb.rows / std::ceil(2 * 1.25 * std::max(1.6 * (edges->right.x() - edges->left.x()), 40.0));
  std::vector<int> green_cols;
  for (int x = 0; x < thumb.cols; ++x) {
    const cv::Vec3b p = thumb.at<cv::Vec3b>(thumb.rows / 2 - 8, x);
    if (p[1] > 150 && p[1] > p[0] + 60 && p[1] > p[2] + 60) green_cols.push_back(x);
  }
  ASSERT_FALSE(green_cols.empty());
  const double width_thumb = (edges->right.x() - edges->left.x()) * scale;
  EXPECT_NEAR(green_cols.back() - green_cols.front(), width_thumb, 3.0);
  EXPECT_NEAR(0.5 * (green_cols.back() + green_cols.front()), 0.5 * thumb.cols, 3.0);
}

// The plot sheet as a browser shows it: Debian's Chromium, headless, loads it with no console
// message, every picture it names is there, and it renders to a picture.
TEST(WriteReport, ChromiumRendersThePlotSheetCleanly) {
  ASSERT_EQ(std::system("command -v chromium > /dev/null"), 0)
      << "chromium is missing: scripts/install-deps.sh installs it";
  const std::vector<stems::Stem> stems = {StemAt(6.0, 0.0, 0.3), StemAt(-4.0, 3.0, 0.2)};
  const std::vector<StampedPose> keyframes = {{0.0, OutwardPose(0.0)}, {1.5, OutwardPose(2.5)}};
  cv::Mat image(kCamera.height, kCamera.width, CV_8UC3, cv::Scalar(90, 120, 80));
  const std::vector<cv::Mat> images = {image, image};
  ReportInput in;
  in.stems = &stems;
  in.camera = &kCamera;
  in.keyframes = &keyframes;
  in.images = &images;
  in.metadata = {{"arm radius", "1.00 m"}};
  in.figures = {{"stems/ha", "64"}};
  in.stand_table = {
      {20.0, 25.0, 1, 31.8, 1.0}, {25.0, 30.0, 0, 0.0, 0.0}, {30.0, 35.0, 1, 31.8, 2.2}};
  ReportOptions o;
  o.map.north_azimuth_deg = 40.0;
  const auto dir = std::filesystem::path(::testing::TempDir()) / "stemmap_report_chromium";
  std::filesystem::remove_all(dir);
  WriteReport(o, in, dir);
  const std::string html = ReadFileToString(dir / "report.html");
  for (size_t p = html.find("src=\""); p != std::string::npos; p = html.find("src=\"", p + 1)) {
    const std::string src = html.substr(p + 5, html.find('"', p + 5) - p - 5);
    EXPECT_TRUE(std::filesystem::exists(dir / src)) << src;
  }
  const std::string url = "file://" + std::filesystem::absolute(dir / "report.html").string();
  const std::string chromium =
      "chromium --headless=new --no-sandbox --disable-gpu --hide-scrollbars "
      "--enable-logging=stderr "
      "--v=0 --window-size=1000,1400 ";
  ASSERT_EQ(std::system((chromium + "--dump-dom " + url + " > " + (dir / "dom.html").string() +
                         " 2> " + (dir / "console.log").string())
                            .c_str()),
            0);
  EXPECT_NE(ReadFileToString(dir / "dom.html").find("<h2>Stand table</h2>"), std::string::npos);
  EXPECT_EQ(ReadFileToString(dir / "console.log").find("CONSOLE"), std::string::npos)
      << ReadFileToString(dir / "console.log");
  ASSERT_EQ(std::system((chromium + "--screenshot=" + (dir / "sheet.png").string() + " " + url +
                         " 2> /dev/null")
                            .c_str()),
            0);
  const cv::Mat shot = cv::imread((dir / "sheet.png").string());
  ASSERT_FALSE(shot.empty());
  EXPECT_EQ(shot.cols, 1000);
  // Not a blank page: the map, the bars and the pictures put dark and green pixels on it.
  cv::Scalar mean, sd;
  cv::meanStdDev(shot, mean, sd);
  EXPECT_GT(sd[1], 10.0);
}

TEST(WriteReport, ListsTheTreesWithoutPicturesWhenNoImagesWereKept) {
  const std::vector<stems::Stem> stems = {StemAt(6.0, 0.0, 0.3)};
  const std::vector<StampedPose> keyframes = {{0.0, OutwardPose(0.0)}};
  const std::vector<cv::Mat> no_images;
  ReportInput in;
  in.stems = &stems;
  in.camera = &kCamera;
  in.keyframes = &keyframes;
  in.images = &no_images;
  const auto dir = std::filesystem::path(::testing::TempDir()) / "stemmap_report_no_images";
  std::filesystem::remove_all(dir);
  EXPECT_EQ(WriteReport({}, in, dir).thumbnails, 0);
  const std::string html = ReadFileToString(dir / "report.html");
  EXPECT_NE(html.find("<tr id=\"tree-1\">"), std::string::npos);
  EXPECT_NE(html.find("no picture kept"), std::string::npos);
}

}  // namespace
}  // namespace stemmap::report
