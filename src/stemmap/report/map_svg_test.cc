#include "stemmap/report/map_svg.h"

#include <gtest/gtest.h>

#include "stemmap/core/error.h"

namespace stemmap::report {
namespace {

stems::Stem MakeStem(double x, double y, double dbh_m, bool occluded = false) {
  stems::Stem s;
  s.centre_xy = {x, y};
  s.dbh_m = dbh_m;
  if (occluded) s.flags.Set(stems::StemFlag::kOccluded);
  return s;
}

int Count(const std::string& s, const std::string& what) {
  int n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

TEST(PlotMapSvg, DrawsEveryStemColouredByItsStanding) {
  const std::vector<stems::Stem> stems = {MakeStem(3.0, 1.0, 0.30), MakeStem(-5.0, 2.0, 0.20),
                                          MakeStem(0.0, 10.6, 0.25, /*occluded=*/true)};
  const std::string svg = PlotMapSvg(MapOptions{}, stems, {{1.0, 0.0}, {0.0, 1.0}, {-1.0, 0.0}});
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(Count(svg, "<title>tree "), 3);
  EXPECT_NE(svg.find("<title>tree 1: DBH 30.0 cm</title>"), std::string::npos);
  EXPECT_NE(svg.find("<title>tree 3: DBH 25.0 cm, occluded</title>"), std::string::npos);
  // Two plain stems inside the plot, the third outside it: grey, though flagged.
  EXPECT_EQ(Count(svg, "fill=\"#2f5d2a\""), 2);
  EXPECT_EQ(Count(svg, "fill=\"#b8b8b0\""), 1);
  EXPECT_EQ(Count(svg, "<polyline"), 1);
}

TEST(PlotMapSvg, NearerStemsSitNearerTheCentreOfTheMap) {
  MapOptions o;
  o.size_px = 400;
  const std::string svg = PlotMapSvg(o, {MakeStem(2.0, 0.0, 0.3), MakeStem(8.0, 0.0, 0.3)}, {});
  // Stems on +x: the first circle's cx lies between the centre (200) and the second's.
  auto cx_of = [&](int k) {
    size_t p = 0;
    for (int i = 0; i <= k; ++i) p = svg.find("<title>tree", p + 1);
    const size_t c = svg.rfind("<circle cx=\"", p);
    return std::stod(svg.substr(c + 12));
  };
  EXPECT_GT(cx_of(0), 200.0);
  EXPECT_GT(cx_of(1), cx_of(0));
}

// The circle centre of tree k (0-based) in the SVG.
Eigen::Vector2d CentreOf(const std::string& svg, int k) {
  size_t p = 0;
  for (int i = 0; i <= k; ++i) p = svg.find("<title>tree", p + 1);
  const size_t c = svg.rfind("<circle cx=\"", p);
  const double cx = std::stod(svg.substr(c + 12));
  const size_t cy = svg.find("cy=\"", c);
  return {cx, std::stod(svg.substr(cy + 4))};
}

TEST(PlotMapSvg, AKnownNorthTurnsTheMapNorthUp) {
  MapOptions o;
  o.size_px = 400;
  o.north_azimuth_deg = 120.0;  // north lies 120° counter-clockwise of the first view
  const double a = 120.0 * M_PI / 180, e = a - M_PI / 2;  // east is a quarter turn clockwise
  const std::vector<stems::Stem> stems = {MakeStem(5 * std::cos(a), 5 * std::sin(a), 0.3),
                                          MakeStem(5 * std::cos(e), 5 * std::sin(e), 0.3)};
  const std::string svg = PlotMapSvg(o, stems, {});
  const Eigen::Vector2d north = CentreOf(svg, 0), east = CentreOf(svg, 1);
  EXPECT_NEAR(north.x(), 200.0, 0.2);
  EXPECT_LT(north.y(), 200.0 - 50);
  EXPECT_NEAR(east.y(), 200.0, 0.2);
  EXPECT_GT(east.x(), 200.0 + 50);
  EXPECT_NE(svg.find(">N</text>"), std::string::npos);
  EXPECT_NE(svg.find("first view"), std::string::npos);
}

TEST(PlotMapSvg, ShadesTheHiddenGroundAndKeepsRingLabelsOffTheStems) {
  stems::HiddenSector h;
  h.azimuth_deg = 30.0;
  h.half_width_deg = 5.0;
  h.from_m = 4.0;
  h.to_m = 10.0;
  // A stem where the 4-m ring's label would otherwise go.
  const double a = 22.5 * M_PI / 180;
  const std::string svg =
      PlotMapSvg(MapOptions{}, {MakeStem(4 * std::cos(a), 4 * std::sin(a), 0.3)}, {}, {h});
  EXPECT_EQ(Count(svg, "<polygon"), 1);
  const size_t label = svg.find(">4 m</text>");
  ASSERT_NE(label, std::string::npos);
  const size_t x = svg.rfind("<text x=\"", label);
  const double lx = std::stod(svg.substr(x + 9));
  const double ly = std::stod(svg.substr(svg.find("y=\"", x) + 3));
  EXPECT_GT((Eigen::Vector2d(lx, ly) - CentreOf(svg, 0)).norm(), 30.0);
}

TEST(MapOptions, RejectsNonsense) {
  MapOptions o;
  o.size_px = 10;
  EXPECT_THROW(o.Check(), InputError);
  o = MapOptions{};
  o.plot_radius_m = 0.0;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::report
