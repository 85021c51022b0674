// The outputs of `process` that describe the tree list: plot figures, trees.csv,
// stems_detail.csv and the terminal table.
#include <fmt/format.h>

#include <cmath>
#include <string>

#include "stemmap/core/io.h"
#include "stemmap/pipeline/process.h"  // IWYU pragma: associated

namespace stemmap::pipeline {

nlohmann::json PlotSummaryJson(const stems::PlotFigures& figures,
                               const stems::Visibility& visibility, int listed_stems,
                               double plot_radius_m, double min_dbh_cm) {
  nlohmann::json warnings = nlohmann::json::array();
  if (listed_stems == 0) {
    warnings.push_back(
        fmt::format("no stem of {:.0f} cm or more found, so the plot figures are empty: does the "
                    "video show the trunks at breast height?",
                    min_dbh_cm));
  } else if (figures.stems == 0) {
    warnings.push_back(fmt::format("no stem found within the {:.1f}-m plot radius", plot_radius_m));
  }
  auto interval = [](const stems::Interval& i) { return nlohmann::json::array({i.low, i.high}); };
  nlohmann::json hidden = nlohmann::json::array();
  for (const stems::HiddenSector& h : visibility.sectors) {
    hidden.push_back({{"behind_tree_id", h.tree + 1},
                      {"azimuth_deg", h.azimuth_deg},
                      {"half_width_deg", h.half_width_deg},
                      {"from_m", h.from_m},
                      {"to_m", h.to_m},
                      {"area_m2", h.area_m2}});
  }
  nlohmann::json table = nlohmann::json::array();
  for (const stems::DbhClass& c : figures.stand_table) {
    table.push_back({{"from_cm", c.from_cm},
                     {"to_cm", c.to_cm},
                     {"stems", c.stems},
                     {"stems_per_ha", c.stems_per_ha},
                     {"basal_area_m2_per_ha", c.basal_area_m2_per_ha}});
  }
  const stems::OcclusionCorrection& oc = figures.occlusion;
  const nlohmann::json occlusion = {
      {"model", stems::DetectionModelName(oc.fit.model)},
      {"sigma_m", oc.fit.sigma_m},
      {"shape", oc.fit.shape},
      {"aic", oc.fit.aic},
      {"detection_probability", oc.fit.detection_probability},
      {"stems_per_ha", oc.stems_per_ha},
      {"stems_per_ha_95", interval(oc.stems_per_ha_95)},
      {"basal_area_m2_per_ha", oc.basal_area_m2_per_ha},
      {"basal_area_m2_per_ha_95", interval(oc.basal_area_m2_per_ha_95)}};
  return {{"radius_m", plot_radius_m},
          {"area_m2", figures.plot_area_m2},
          {"min_dbh_cm", min_dbh_cm},
          {"stems", figures.stems},
          {"stems_per_ha", figures.stems_per_ha},
          {"basal_area_m2_per_ha", figures.basal_area_m2_per_ha},
          {"qmd_cm", figures.qmd_cm},
          {"stems_per_ha_95", interval(figures.stems_per_ha_95)},
          {"basal_area_m2_per_ha_95", interval(figures.basal_area_m2_per_ha_95)},
          {"qmd_cm_95", interval(figures.qmd_cm_95)},
          {"dominant_diameter_cm", figures.dominant_diameter_cm},
          {"dominant_diameter_cm_95", interval(figures.dominant_diameter_cm_95)},
          {"borderline_stems", figures.borderline_stems},
          {"borderline_counted", figures.borderline_counted},
          {"stand_table", table},
          {"occlusion_corrected", occlusion},
          {"hidden_area_m2", visibility.hidden_area_m2},
          {"hidden_share",
           visibility.plot_area_m2 > 0 ? visibility.hidden_area_m2 / visibility.plot_area_m2 : 0.0},
          {"expected_hidden_stems", figures.expected_hidden_stems},
          {"hidden", hidden},
          {"warnings", warnings}};
}

void WriteStandTableCsv(const std::filesystem::path& path, const stems::PlotFigures& figures) {
  std::string s = "dbh_from_cm,dbh_to_cm,stems,stems_per_ha,basal_area_m2_per_ha\n";
  for (const stems::DbhClass& c : figures.stand_table) {
    s += fmt::format("{:g},{:g},{},{:.1f},{:.3f}\n", c.from_cm, c.to_cm, c.stems, c.stems_per_ha,
                     c.basal_area_m2_per_ha);
  }
  s += fmt::format("all,,{},{:.1f},{:.3f}\n", figures.stems, figures.stems_per_ha,
                   figures.basal_area_m2_per_ha);
  WriteFileAtomic(path, s);
}

void WriteStemDetails(const std::filesystem::path& path, const std::vector<stems::Stem>& stems) {
  std::string s =
      "tree_id,x_m,y_m,dbh_tangent_cm,dbh_tangent_sd_cm,dbh_slice_cm,dbh_circle_cm,n_views,"
      "arc_deg,lean_deg,pass_through,n_points,tried_views,two_sided_views,fit_rms_px,bark_pairs,"
      "bark_ncc,bark_shift_cm,jagged_share,dbh_seen_cm,dbh_hidden_max_cm\n";
  int id = 0;
  for (const stems::Stem& t : stems) {
    const stems::FitEvidence& e = t.evidence;
    s += fmt::format(
        "{},{:.3f},{:.3f},{:.2f},{:.2f},{:.2f},{:.2f},{},{:.1f},{:.1f},{:.2f},{},{},{},{:.2f},{},"
        "{:.3f},{:.1f},{:.2f},{:.2f},{:.2f}\n",
        ++id, t.centre_xy.x(), t.centre_xy.y(), 100 * t.dbh_tangent_m, 100 * t.dbh_tangent_sd_m,
        100 * t.dbh_slice_m, 100 * t.dbh_circle_m, t.n_views, t.arc_deg, t.lean_deg, t.pass_through,
        t.n_points, e.tried_views, e.two_sided_views, e.rms_px, e.bark_pairs, e.bark_ncc,
        100 * e.bark_shift_m, e.jagged_share, 100 * t.dbh_seen_m, 100 * t.dbh_hidden_max_m);
  }
  WriteFileAtomic(path, s);
}

std::string ProcessResult::Table() const {
  std::string s = fmt::format("{:>4} {:>8} {:>8} {:>8} {:>8} {:>6}  {}\n", "tree", "dist m",
                              "az deg", "DBH cm", "SD cm", "views", "flags");
  int id = 0;
  for (const stems::Stem& t : stems) {
    double az = std::atan2(t.centre_xy.y(), t.centre_xy.x()) * 180.0 / M_PI;
    if (az < 0) az += 360.0;
    s += fmt::format("{:>4} {:>8.2f} {:>8.1f} {:>8.1f} {:>8.1f} {:>6}  {}\n", ++id,
                     t.centre_xy.norm(), az, 100 * t.dbh_m, 100 * t.dbh_sd_m, t.n_views,
                     fmt::join(t.flags.Names(), ";"));
  }
  const stems::PlotFigures& f = figures;
  s += fmt::format(
      "{} stems in the plot: {:.0f} stems/ha ({:.0f}-{:.0f}), basal area {:.1f} m²/ha "
      "({:.1f}-{:.1f}), QMD {:.1f} cm ({:.1f}-{:.1f}); 95 % intervals\n",
      f.stems, f.stems_per_ha, f.stems_per_ha_95.low, f.stems_per_ha_95.high,
      f.basal_area_m2_per_ha, f.basal_area_m2_per_ha_95.low, f.basal_area_m2_per_ha_95.high,
      f.qmd_cm, f.qmd_cm_95.low, f.qmd_cm_95.high);
  return s;
}

}  // namespace stemmap::pipeline
