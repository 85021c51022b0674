#include "stemmap/stems/refine.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>

namespace stemmap::stems {

namespace {

// The cloud's radius of a stem: its slice's width, else the circle fitted to it.
double CloudRadius(const Stem& s) {
  return 0.5 * (s.dbh_slice_m > 0 ? s.dbh_slice_m : s.dbh_circle_m);
}

// Whether two stems' circles overlap: one stem measured twice.
bool CirclesOverlap(const Stem& a, const Stem& b) {
  return (a.centre_xy - b.centre_xy).norm() < 0.5 * (a.dbh_m + b.dbh_m);
}

bool WidthRestsOnBothSides(const Stem& s) {
  return !s.flags.Has(StemFlag::kOneSided) && !s.flags.Has(StemFlag::kNoSilhouette);
}

}  // namespace

int DropStemsFittedTwice(double min_bark_gap_m, std::vector<Stem>* stems) {
  std::vector<size_t> order(stems->size());
  std::iota(order.begin(), order.end(), 0);
  // Judged first: a width resting on one side or on the cloud (a stem behind a nearer one, its
  // seen side a leaf's edge, can come out several times too wide and so overlap the stem's own
  // two-sided fit); then the farthest-moved fit. Ties keep the list's order.
  auto judged_before = [&](size_t a, size_t b) {
    const Stem &sa = (*stems)[a], &sb = (*stems)[b];
    if (WidthRestsOnBothSides(sa) != WidthRestsOnBothSides(sb)) return WidthRestsOnBothSides(sb);
    return sa.fit_shift_m > sb.fit_shift_m;
  };
  std::stable_sort(order.begin(), order.end(), judged_before);
  std::vector<char> drop(stems->size(), 0);
  for (size_t i : order) {
    const Stem& a = (*stems)[i];
    for (size_t j = 0; j < stems->size() && !drop[i]; ++j) {
      const Stem& b = (*stems)[j];
      if (j == i || drop[j] || judged_before(j, i)) continue;
      const double gap = (a.centre_xy - b.centre_xy).norm() - 0.5 * (a.dbh_m + b.dbh_m);
      if (gap < min_bark_gap_m) drop[i] = 1;
    }
  }
  int dropped = 0;
  std::vector<Stem> kept;
  for (size_t i = 0; i < stems->size(); ++i) {
    if (drop[i]) {
      ++dropped;
      spdlog::debug("stems: ({:.2f}, {:.2f}) dropped: its fit moved {:.2f} m onto another stem",
                    (*stems)[i].centre_xy.x(), (*stems)[i].centre_xy.y(), (*stems)[i].fit_shift_m);
    } else {
      kept.push_back(std::move((*stems)[i]));
    }
  }
  *stems = std::move(kept);
  return dropped;
}

double BarkPastOutlineShare(std::span<const Eigen::Vector2d> slice_xy,
                            const Eigen::Vector2d& centre, double radius_m) {
  const double distance_m = centre.norm();
  if (!(radius_m > 0) || distance_m <= radius_m) return 0.0;
  const double half_rad = std::asin(radius_m / distance_m);
  const double bearing = std::atan2(centre.y(), centre.x());
  const double face_m = distance_m - radius_m;
  const double face_tol_m = std::max(0.05, radius_m);
  int inside = 0;
  std::array<int, 2> past{0, 0};
  for (const Eigen::Vector2d& p : slice_xy) {
    const double u = std::remainder(std::atan2(p.y(), p.x()) - bearing, 2 * M_PI) / half_rad;
    if (std::abs(u) < 1) {
      ++inside;
    } else if (std::abs(u) > 1.3 && std::abs(u) < 4 && std::abs(p.norm() - face_m) < face_tol_m) {
      ++past[u > 0];
    }
  }
  return inside > 0 ? static_cast<double>(std::max(past[0], past[1])) / inside : 0.0;
}

double JudgedPixelM(const MeasureOptions& o, double distance_m, double fx_px) {
  return std::max(distance_m / fx_px, o.min_judged_px_m);
}

SilhouetteVerdict JudgeSilhouetteFit(const MeasureOptions& o, const Stem& s, const TangentFit& f,
                                     double px_m, bool bark_lines_up,
                                     const std::function<bool()>& part_lines_up_on_bark) {
  // A silhouette fit far from the cloud's width locked onto something else (a furrow, a
  // neighbour): keep the cloud's estimate and say so. A stem partly hidden from the stereo
  // pairs is wider than its points: silhouettes on both sides in several views that agree to
  // about a pixel outrank them, and a part with little surface at breast height needs them.
  const double r0 = CloudRadius(s);
  const bool loose_narrower = f.radius_m < r0 && f.rms_m > o.loose_fit_rms_px * px_m;
  const bool tight = f.rms_m < o.tight_fit_rms_px * px_m;
  const bool loose_wider = f.radius_m > o.loose_wider_max_over_cloud * r0 && !tight;
  // A fit narrower than the points whose bark goes on past one of its outlines at its face lies
  // inside the stem, between a line on its bark and one true outline
  // (narrower_max_bark_past_outline): neither near the points' width nor outranking it.
  const double bark_past =
      f.radius_m < r0 ? BarkPastOutlineShare(s.slice_xy, f.centre, f.radius_m) : 0.0;
  const bool inside_stem =
      o.narrower_max_bark_past_outline > 0 && bark_past >= o.narrower_max_bark_past_outline;
  if (inside_stem && f.ok) {
    spdlog::debug("stems: fit ({:.2f}, {:.2f}) {:.3f} m inside the stem's {:.3f} m: bark {:.2f}",
                  f.centre.x(), f.centre.y(), 2 * f.radius_m, 2 * r0, bark_past);
  }
  const bool near_cloud = std::abs(f.radius_m - r0) < 0.35 * r0 + 0.01 && !loose_narrower &&
                          !loose_wider && !inside_stem;
  const bool two_sided = f.two_sided_views >= 3 && tight;
  const bool wider_two_sided =
      two_sided && f.radius_m > r0 && f.radius_m < o.tangent.WidestFitScale() * r0;
  const bool whole_on_bark = bark_lines_up && 2 * f.two_sided_views >= f.tried_views &&
                             f.rms_m < o.weak_on_bark_max_rms_px * px_m;
  const bool confirmed = !s.weak_support || two_sided || whole_on_bark;
  // Both sides in most views, agreeing to a pixel, narrower than the points: the cloud took in
  // what stands beside the stem (a shrub, a sapling, a sapling's leaves). A furrow does not stay
  // tangent across views. Where the bark lines up on the fit, a share of the views will do: a
  // circle around two things does not warp one view's bark onto the next (a circle inside a
  // stem may, and its points tell: inside_stem).
  const double two_sided_share = bark_lines_up ? o.narrower_on_bark_two_sided_share : 0.5;
  const bool inside_part = f.radius_m < r0 && f.radius_m > o.tangent.narrow_min_share * r0;
  const bool narrower_two_sided = two_sided &&
                                  f.two_sided_views >= two_sided_share * f.tried_views &&
                                  inside_part && !inside_stem;
  // Whole in nearly every view, tight, on bark, however narrow a share of the part
  // (MeasureOptions::whole_in_wide_part_two_sided_share), unless the part's own circle lines up
  // on bark: then it is one stem, and the fit holds a sunlit strip of it or a line on its bark
  // and one outline (its points past the fit lie nearer than the fit's face, where
  // BarkPastOutlineShare does not count them).
  const bool whole_in_wide_part =
      o.whole_in_wide_part_two_sided_share > 0 && f.ok && two_sided && bark_lines_up &&
      !inside_stem && f.radius_m <= o.tangent.narrow_min_share * r0 &&
      f.two_sided_views >= o.whole_in_wide_part_two_sided_share * f.tried_views &&
      !(part_lines_up_on_bark && part_lines_up_on_bark());
  // A sapling's thin stem outlined inside the part its leaves or smear widened
  // (MeasureOptions::sapling_outline_max_dbh_cm).
  const bool sapling_outline =
      two_sided && 2 * f.radius_m < 0.01 * o.sapling_outline_max_dbh_cm && inside_part;
  // A fit from one side that came out wider than the points rests on nothing that can check it
  // (an occluder's edge, the slack of a one-sided circle); a confirmed stem keeps the cloud's
  // width.
  const bool one_sided = f.two_sided_views < 3;
  if (f.ok && confirmed && one_sided && f.radius_m > o.one_sided_max_over_cloud * r0) {
    // Unless it stays tangent to one circle across views to about a pixel, on a part the cloud
    // saw as a real stem: then a nearer stem hid the rest of it from the stereo pairs, and the
    // one side seen is a better width than the points.
    const bool held = tight && r0 >= o.one_sided_min_cloud_radius_m &&
                      f.radius_m < o.tangent.WidestFitScale() * r0;
    return held ? SilhouetteVerdict::kUse : SilhouetteVerdict::kKeepCloud;
  }
  // A smeared part's width across the line of sight is rough, but not off by half: a fit beyond
  // half or twice it caught something else (a neighbour, one side of the stem), though the
  // silhouettes it found still confirm a stem. Wider than the points, it must be two-sided like
  // any other wider fit (a trunk just behind the stem can widen loose silhouettes), unless it
  // keeps near their width (near_cloud), as a fit on a part that is not smeared may.
  const bool smeared_width = f.radius_m > 0.5 * r0 && f.radius_m < 2.0 * r0 &&
                             (f.radius_m <= r0 || two_sided || near_cloud);
  const bool plausible = f.ok && confirmed &&
                         (sapling_outline || whole_in_wide_part ||
                          (s.depth_smeared ? smeared_width || narrower_two_sided
                                           : near_cloud || wider_two_sided || narrower_two_sided));
  if (plausible) return SilhouetteVerdict::kUse;
  if (f.ok && confirmed && s.depth_smeared) return SilhouetteVerdict::kKeepCloud;
  // A smeared or weakly supported part is a stem only if silhouettes confirm it; when
  // silhouettes are required (the default), a part where none were found is no stem either.
  if ((o.require_silhouette && !f.ok) || s.depth_smeared || s.weak_support) {
    return SilhouetteVerdict::kDrop;
  }
  return SilhouetteVerdict::kKeepCloud;
}

bool OutlinesTheStemInMoreViews(const Stem& core, const Stem& fit) {
  const auto share = [](const FitEvidence& e) {
    return e.tried_views > 0 ? static_cast<double>(e.two_sided_views) / e.tried_views : 0.0;
  };
  return CirclesOverlap(core, fit) && share(core.evidence) > share(fit.evidence);
}

bool CoresOneBehindAnother(double max_depth_smear_m, std::span<const Stem> cores) {
  for (size_t i = 0; i < cores.size(); ++i) {
    for (size_t j = i + 1; j < cores.size(); ++j) {
      const double apart_m = std::abs(cores[i].face_range_m - cores[j].face_range_m);
      if (apart_m > std::max(cores[i].dbh_m, cores[j].dbh_m) + max_depth_smear_m) return true;
    }
  }
  return false;
}

PartOutcome ResolvePart(const MeasureOptions& o, Stem part,
                        const std::function<RefinedStem(Stem)>& refine, std::vector<Stem>* kept) {
  PartOutcome out;
  std::vector<Stem> cores = std::exchange(part.alternatives, {});
  std::vector<Stem> larger = std::exchange(part.larger_cloud_part, {});
  const double part_dbh_m = 2 * CloudRadius(part);
  const bool mixed_part_core = part.mixed_part_core;
  RefinedStem part_refined = refine(std::move(part));
  const SilhouetteVerdict verdict = part_refined.verdict;
  Stem& s = part_refined.stem;
  const bool clean = part_refined.clean, whole = part_refined.whole;
  const bool sides_past_nearer = part_refined.sides_past_nearer;
  // A core of a part no stem as a whole stands, as any part's core, on clean silhouettes only.
  if (mixed_part_core && verdict == SilhouetteVerdict::kUse && !clean) {
    spdlog::debug(
        "stems: core ({:.2f}, {:.2f}) of a part no stem as a whole dropped: its "
        "silhouettes are not clean",
        s.centre_xy.x(), s.centre_xy.y());
    out.dropped = 1;
    return out;
  }
  // A fit far narrower than a smeared part with several cores may be one of stems standing
  // one behind another, and a fit of cores at ranges no one stem spans takes in two of them:
  // the cores decide, when two or more of them fit on their own.
  const bool several_cores = verdict == SilhouetteVerdict::kUse && cores.size() >= 2;
  const bool narrow_in_wide = several_cores && s.dbh_tangent_m < o.narrow_fit_share * part_dbh_m;
  const bool cores_decide =
      narrow_in_wide || (several_cores && o.try_cores_one_behind_another &&
                         CoresOneBehindAnother(o.stems.max_depth_smear_m, cores));
  if (verdict == SilhouetteVerdict::kUse && !cores_decide) {
    out.fitted = 1;
    kept->push_back(std::move(s));
    return out;
  }
  // No silhouette fits the part as a whole: it may be stems one behind another, or a stem and
  // a shrub or sapling beside it. Each dense core is a stem when its own silhouettes fit it
  // cleanly, clear of the stems kept so far; they replace the part. A part kept on its cloud
  // is one stem, maybe widened by a shrub or by stereo's smear: a core far narrower than it is
  // a piece of its bark, unless its own silhouettes show both sides in most of its views (a
  // piece of bark has no such outline; the stem the cloud smeared wide has).
  const size_t before = kept->size();
  const double min_core_dbh_m =
      verdict == SilhouetteVerdict::kKeepCloud ? o.min_core_share * s.dbh_m : 0.0;
  // Cores that overlap are one stem: the one with both sides in most views stands first.
  std::vector<RefinedStem> refined;
  for (Stem& core : cores) refined.push_back(refine(std::move(core)));
  std::ranges::stable_sort(refined, [](const RefinedStem& a, const RefinedStem& b) {
    if (a.whole != b.whole) return a.whole;
    return a.stem.evidence.two_sided_views > b.stem.evidence.two_sided_views;
  });
  int whole_cores = 0;
  for (RefinedStem& r : refined) {
    Stem& c = r.stem;
    if (r.verdict != SilhouetteVerdict::kUse || !r.clean ||
        (c.dbh_m < min_core_dbh_m && !r.whole)) {
      continue;
    }
    const bool overlaps =
        std::ranges::any_of(*kept, [&](const Stem& k) { return CirclesOverlap(k, c); });
    if (!overlaps) {
      kept->push_back(std::move(c));
      whole_cores += r.whole;
    }
  }
  const int from_cores = static_cast<int>(kept->size() - before);
  spdlog::debug("stems: part ({:.2f}, {:.2f}) fit {:.3f} whole {}: {} of {} cores kept, {} whole",
                s.centre_xy.x(), s.centre_xy.y(), s.dbh_m, whole, from_cores, cores.size(),
                whole_cores);
  // One core alone replaces the part's fit only when it shows both sides in most of its views
  // and the part's fit does not (that fit caught what stands beside the stem), or when both
  // outline one stem and the core's shows both sides in more of its views: a narrower circle
  // inside a stem matches lines of its bark in some views, its outline matches in nearly all.
  // Not where the cores decided for facing the centre from ranges apart, the part's fit as wide
  // as the part: stems one behind another are two, and with one core standing the part is one
  // stem whose fit outlines it (the ranges apart were stereo's smear of a far stem; the core's
  // circle, inside it, followed the shading across its bark).
  const bool one_whole_core = narrow_in_wide && from_cores == 1 && whole_cores == 1 &&
                              (!whole || OutlinesTheStemInMoreViews(kept->back(), s));
  if (cores_decide && from_cores < 2 && !one_whole_core) {
    // Fewer than two: the whole part's fit stands.
    kept->resize(before);
    out.fitted = 1;
    kept->push_back(std::move(s));
    return out;
  }
  out.fitted = out.from_cores = from_cores;
  if (from_cores > 0) return out;
  // Kept on its cloud behind a nearer stem, which hid part of it from the stereo pairs, its
  // width is a lower bound: the larger cloud's part, kept so too or fitted, stands in where it
  // is wider.
  if (sides_past_nearer && !larger.empty()) {
    RefinedStem r = refine(std::move(larger.front()));
    larger.clear();
    const bool stands = r.verdict == SilhouetteVerdict::kUse || r.sides_past_nearer;
    if (stands && r.stem.dbh_m > s.dbh_m) {
      spdlog::debug(
          "stems: part ({:.2f}, {:.2f}) behind a nearer stem widened by the larger "
          "cloud's: dbh {:.3f} over {:.3f}",
          s.centre_xy.x(), s.centre_xy.y(), r.stem.dbh_m, s.dbh_m);
      s = std::move(r.stem);
    }
  }
  if (verdict == SilhouetteVerdict::kKeepCloud) {
    kept->push_back(std::move(s));
    return out;
  }
  // The larger cloud's part stands in when its silhouettes are clean (both sides in a quarter of
  // its views, on one circle to a couple of pixels), placed and sized by them, or by its cloud
  // when they agree with its width (a sapling's smeared points are far wider than its edges).
  if (!larger.empty()) {
    RefinedStem r = refine(std::move(larger.front()));
    const bool stands = r.verdict == SilhouetteVerdict::kUse ||
                        (r.verdict == SilhouetteVerdict::kKeepCloud && r.agrees_with_cloud);
    if ((stands && r.clean) || r.sides_past_nearer) {
      spdlog::debug("stems: part ({:.2f}, {:.2f}) replaced by the larger cloud's", s.centre_xy.x(),
                    s.centre_xy.y());
      kept->push_back(std::move(r.stem));
      out.fitted = 1;
      return out;
    }
    spdlog::debug("stems: the larger cloud's part for ({:.2f}, {:.2f}): verdict {} clean {}",
                  s.centre_xy.x(), s.centre_xy.y(), static_cast<int>(r.verdict), r.clean);
  }
  out.dropped = 1;
  return out;
}

void PlaceFittedOccluders(std::span<const Stem> fitted, std::span<const Eigen::Vector3d> leaves,
                          size_t part, bool unfitted_hides,
                          std::vector<Eigen::Vector3d>* occluders) {
  if (fitted.empty() && !unfitted_hides) (*occluders)[part] = kNoOccluder;
  for (size_t k = 0; k < leaves.size(); ++k) {
    if (k == 0 && fitted.empty()) {
      (*occluders)[part] = leaves[k];
    } else {
      occluders->push_back(leaves[k]);
    }
  }
  for (size_t k = 0; k < fitted.size(); ++k) {
    const Stem& s = fitted[k];
    const Eigen::Vector3d circle(s.centre_xy.x(), s.centre_xy.y(),
                                 0.5 * (s.dbh_tangent_m > 0 ? s.dbh_tangent_m : s.dbh_m));
    if (k == 0) {
      (*occluders)[part] = circle;
    } else {
      occluders->push_back(circle);
    }
  }
}

int AddLargerCloudOnlyStems(const MeasureOptions& o, std::vector<Stem> candidates,
                            const std::function<RefinedStem(Stem)>& refine, std::vector<Stem>* kept,
                            std::vector<Eigen::Vector3d>* occluders) {
  // The candidate's own circle is its cloud's, often smeared wide along the line of sight: it
  // is taken only where its centre lies on a kept stem. A fit that slides onto one is dropped
  // later (DropStemsFittedTwice).
  return AddStemsWithoutPart(o, std::move(candidates), {o.larger_cloud_part_gap_m}, refine, kept,
                             occluders);
}

int AddStemsWithoutPart(const MeasureOptions& o, std::vector<Stem> candidates,
                        const CandidateTries& tries, const std::function<RefinedStem(Stem)>& refine,
                        std::vector<Stem>* kept, std::vector<Eigen::Vector3d>* occluders) {
  int added = 0, tried = 0;
  for (Stem& c : candidates) {
    if (tried >= tries.max_tries) break;
    const double own_radius = tries.candidate_radius ? 0.5 * c.dbh_m : 0.0;
    const bool taken = std::ranges::any_of(*kept, [&](const Stem& k) {
      return (k.centre_xy - c.centre_xy).norm() - 0.5 * k.dbh_m - own_radius < tries.gap_m;
    });
    if (taken) continue;
    ++tried;
    RefinedStem r = refine(std::move(c));
    spdlog::debug(
        "stems: stem without a part at ({:.2f}, {:.2f}): verdict {}, sharp {}, whole {}, "
        "seen apart {}, whole where no nearer stem hid a side {}, agrees with votes {}, on the "
        "cloud's surface {}; sides clear of nearer stems in {} and {} views",
        r.stem.centre_xy.x(), r.stem.centre_xy.y(), static_cast<int>(r.verdict), r.sharp, r.whole,
        r.seen_apart, r.whole_where_open, r.agrees_with_votes, r.on_cloud_surface,
        r.stem.evidence.clear_side_views[0], r.stem.evidence.clear_side_views[1]);
    // Both sides in half the views to a couple of pixels stand as a part's core would alone.
    // Straight behind a listed stem, each side in views of its own on one circle stands too:
    // the nearer stem hides one side from each end of the arm (SidesSeenApart). Where its bark
    // lines up, both sides in half the views where no nearer stem hid one will do, for a stem
    // the list keeps (a sapling so found would stand as a nearer stem that farther fits are
    // straight behind).
    const bool whole_where_open = o.larger_cloud_whole_where_open && r.whole_where_open &&
                                  r.stem.dbh_m >= 0.01 * o.min_dbh_cm;
    // Or where the cloud's rays end on the fitted circle: the surface is there.
    if (r.verdict != SilhouetteVerdict::kUse ||
        !(r.sharp || r.whole || r.seen_apart || whole_where_open || r.agrees_with_votes ||
          r.on_cloud_surface)) {
      continue;
    }
    r.stem.flags.Set(StemFlag::kSilhouetteOnly);
    occluders->emplace_back(r.stem.centre_xy.x(), r.stem.centre_xy.y(), 0.5 * r.stem.dbh_m);
    kept->push_back(std::move(r.stem));
    ++added;
  }
  return added;
}

bool HasSharpSilhouettes(const TangentFit& f, double max_rms_px, double px_m) {
  return f.ok && f.two_sided_views >= 3 && f.rms_m < max_rms_px * px_m;
}

bool SidesSeenApartPastNearer(const TangentOptions& o, const TangentFit& f,
                              const std::array<int, 2>& clear_side_views, double px_m) {
  return SidesSeenApart(o, f, px_m) &&
         std::min(clear_side_views[0], clear_side_views[1]) >= o.min_views_each_side;
}

bool StandsOnItsOwnSilhouettes(const TangentOptions& o, const TangentFit& f, double px_m) {
  if (!f.ok) return false;
  // Both sides in a few views (the nearer stem hides the rest) on one circle to a couple of
  // pixels, or many silhouettes on one circle to about a pixel: the nearer stem's edges, seen
  // from along the arm, fan out behind it and stay tangent to no one circle there.
  // Or each side in several views, on one circle to about a pixel: seen past the nearer stem
  // from either end of the arm.
  return (f.two_sided_views >= 3 && f.rms_m < 2 * px_m) ||
         (f.rays >= 2 * o.min_rays && f.rms_m < o.narrow_max_rms_px * px_m) ||
         SidesSeenApart(o, f, px_m);
}

namespace {

// The angular half-width, from the plot centre, of the widest of the `nearer` stems that `centre`
// lies straight behind (farther than its far side, within its angular width); 0 if none.
double WidestNearerStemAhead(std::span<const Stem> nearer, const Eigen::Vector2d& centre) {
  const double d = centre.norm();
  double widest = 0.0;
  for (const Stem& k : nearer) {
    const double dk = k.centre_xy.norm(), rk = 0.5 * k.dbh_m;
    if (dk + rk >= d || dk <= rk) continue;
    const double apart = std::abs(std::remainder(
        std::atan2(centre.y(), centre.x()) - std::atan2(k.centre_xy.y(), k.centre_xy.x()),
        2 * M_PI));
    const double half_width = std::asin(rk / dk);
    if (apart < half_width) widest = std::max(widest, half_width);
  }
  return widest;
}

}  // namespace

namespace {

// The side (0 image left, 1 right) of the stem (c, r) toward the listed stem in front of it
// whose outline, seen from the plot centre, comes nearest to its own within its angular width
// (overlapping or not), or -1 where none does.
int SideTowardNearerStem(std::span<const Stem> nearer, const Eigen::Vector2d& c, double r) {
  const double d = c.norm();
  if (d <= r) return -1;
  const double half = std::asin(r / d), bearing = std::atan2(c.y(), c.x());
  int side = -1;
  double closest = 1e9;
  for (const Stem& k : nearer) {
    const double dk = k.centre_xy.norm(), rk = 0.5 * k.dbh_m;
    if (dk + rk >= d - r || dk <= rk) continue;
    const double apart =
        std::remainder(std::atan2(k.centre_xy.y(), k.centre_xy.x()) - bearing, 2 * M_PI);
    const double gap = std::abs(apart) - std::asin(rk / dk) - half;
    if (gap < half && gap < closest) closest = gap, side = apart > 0 ? 0 : 1;
  }
  return side;
}

// For each listed stem whose width rests on one side or its cloud, where a nearer one hides the
// other side in every view that could show it (MeasureOptions::hidden_side_min_gain): the widest
// it could be with that side hidden (Stem::dbh_hidden_max_m) and the width seen (dbh_seen_m).
// Views of a side that measure a stem's width: as many as a fit with both sides needs (a stem
// whose sides show together in fewer is flagged one_sided).
constexpr int kViewsThatMeasure = 3;

void BoundHiddenSides(const MeasureOptions& o, const PinholeCamera& camera,
                      const std::vector<StampedPose>& keyframes, const std::vector<cv::Mat>& gray,
                      std::vector<Stem>* stems) {
  if (o.hidden_side_min_gain <= 0) return;
  for (Stem& s : *stems) {
    const FitEvidence& e = s.evidence;
    // Sides seen one at a time past the nearer stem measure it.
    if (e.sides_apart) continue;
    const double r = 0.5 * s.dbh_m;
    const int side = SideTowardNearerStem(*stems, s.centre_xy, r);
    if (side < 0) continue;
    // The side toward the nearer stem, clear of it in enough views (three, and a share of those
    // that would show it: hidden_side_min_seen_share), measures it; a width not the fit's
    // (no_silhouette: the cloud's) has no silhouette there.
    const int found = s.flags.Has(StemFlag::kNoSilhouette) ? 0 : e.clear_side_views[side];
    std::vector<Eigen::Vector3d> others;
    for (const Stem& k : *stems) {
      if (&k != &s) others.emplace_back(k.centre_xy.x(), k.centre_xy.y(), 0.5 * k.dbh_m);
    }
    const TangentViews views{&camera, &keyframes, &gray, &others};
    const double breast_z = s.floor_z_m + o.stems.breast_height_m;
    // Where the width seen puts that side, views whose edge search should have found it did not:
    // the stem goes on behind it. (Where no view shows that side, nothing says it is wider.)
    const int open = ViewsShowingSide(o.tangent, views, s.centre_xy, r, side, breast_z);
    spdlog::trace(
        "stems: ({:.2f}, {:.2f}) its {} side toward a nearer stem: {} views clear of "
        "it, {} would show it",
        s.centre_xy.x(), s.centre_xy.y(), side == 0 ? "left" : "right", found, open);
    if (found >= kViewsThatMeasure && found >= o.hidden_side_min_seen_share * open) continue;
    if (open - found < kViewsThatMeasure) continue;
    const double widest = WidestRadiusWithSideHidden(o.tangent, views, s.centre_xy, r, side,
                                                     breast_z, 0.5 * o.stems.max_diameter_m);
    if (widest < o.hidden_side_min_gain * r) continue;
    s.dbh_seen_m = s.dbh_m;
    s.dbh_hidden_max_m = 2 * widest;
    s.hidden_side = side;
    spdlog::debug("stems: ({:.2f}, {:.2f}) {:.1f} cm seen, its {} side hidden: up to {:.1f} cm",
                  s.centre_xy.x(), s.centre_xy.y(), 100 * s.dbh_m, side == 0 ? "left" : "right",
                  200 * widest);
  }
}

}  // namespace

void WidthsFromStand(const MeasureOptions& o, std::vector<Stem>* stems) {
  std::vector<double> measured;
  for (const Stem& s : *stems) {
    if (s.dbh_hidden_max_m <= 0) measured.push_back(s.dbh_m);
  }
  for (Stem& s : *stems) {
    if (s.dbh_hidden_max_m <= 0) continue;
    double sum = 0;
    int n = 0;
    for (const double d : measured) {
      if (d >= s.dbh_seen_m && d <= s.dbh_hidden_max_m) sum += d, ++n;
    }
    s.dbh_m =
        n >= o.hidden_side_stand_min_stems ? sum / n : 0.5 * (s.dbh_seen_m + s.dbh_hidden_max_m);
    s.centre_xy = GrownHoldingFace(s.centre_xy, 0.5 * s.dbh_seen_m, s.hidden_side, 0.5 * s.dbh_m);
    s.flags.Set(StemFlag::kWidthFromStand);
  }
}

bool InShadowOfNearerStem(std::span<const Stem> nearer, const Eigen::Vector2d& centre) {
  return WidestNearerStemAhead(nearer, centre) > 0;
}

bool NoWiderThanANearerStemItIsBehind(std::span<const Stem> nearer, const Eigen::Vector2d& centre,
                                      double radius_m) {
  const double d = centre.norm(), widest = WidestNearerStemAhead(nearer, centre);
  return widest > 0 && d > radius_m && std::asin(radius_m / d) <= widest;
}

bool OneSideSeenPastNearer(const TangentOptions& o, const TangentViews& views,
                           const TangentFit& fit, double breast_z, double px_m, int min_views) {
  if (min_views <= 0 || !fit.ok || fit.rms_m >= o.narrow_max_rms_px * px_m) return false;
  const std::array<int, 2> seen = {fit.SideViews(0), fit.SideViews(1)};
  const int side = seen[0] >= seen[1] ? 0 : 1, hidden = 1 - side;
  if (seen[hidden] >= o.min_views_each_side || seen[side] < min_views) return false;
  if (SideViewsClearOfNearerStems(o, views, fit, breast_z)[side] < seen[side]) return false;
  // Where the circle puts the other side clear of the nearer stems, it shows.
  const int open = ViewsShowingSide(o, views, fit.centre, fit.radius_m, hidden, breast_z);
  return open - seen[hidden] < o.min_views_each_side;
}

bool HoldOnFaceBehindNearer(const Stem& part, double radius0, std::span<const Stem> nearer,
                            const TangentOptions& topt, const TangentViews& views, double breast_z,
                            double px_m, int one_side_min_views,
                            const std::function<bool()>& one_side_may_stand, TangentFit* fit) {
  const bool one_side_per_view = !fit->ok || fit->two_sided_views < 3;
  const double widest_ahead = WidestNearerStemAhead(nearer, part.centre_xy);
  if (!one_side_per_view || part.weak_support || part.face_range_m <= 0 ||
      !(widest_ahead > 0 || (fit->ok && InShadowOfNearerStem(nearer, fit->centre)))) {
    return false;
  }
  // The widest stem whose face lies face_range_m out that the nearer stems hide from the plot
  // centre: r / (face + r) = sin(their angular half-width).
  const double hidden_sin = std::sin(widest_ahead);
  const double max_radius_m = part.face_range_m * hidden_sin / (1 - hidden_sin);
  TangentFit held = FitSidesOnFace(topt, views, part.centre_xy, radius0, max_radius_m,
                                   part.face_range_m, breast_z);
  const bool apart = SidesSeenApart(topt, held, px_m) &&
                     NoWiderThanANearerStemItIsBehind(nearer, held.centre, held.radius_m);
  const bool one_side =
      !apart && OneSideSeenPastNearer(topt, views, held, breast_z, px_m, one_side_min_views) &&
      one_side_may_stand();
  if (!apart && !one_side) return false;
  spdlog::debug(
      "stems: ({:.2f}, {:.2f}) held on its face {:.2f} m out: ({:.2f}, {:.2f}) r {:.3f}, {}",
      part.centre_xy.x(), part.centre_xy.y(), part.face_range_m, held.centre.x(), held.centre.y(),
      held.radius_m, apart ? "sides seen apart" : "one side seen past the nearer stem");
  *fit = std::move(held);
  return true;
}

bool ShowsSidesPastNearerStem(const MeasureOptions& o, const Stem& part, double radius_m,
                              std::span<const Stem> nearer, const std::array<int, 2>& side_views) {
  return o.sides_past_nearer_min_views > 0 && !part.weak_support &&
         NoWiderThanANearerStemItIsBehind(nearer, part.centre_xy, radius_m) &&
         side_views[0] + side_views[1] >= o.sides_past_nearer_min_views;
}

double JaggedSilhouetteShare(const MeasureOptions& o, const TangentFit& fit, double px_m) {
  return fit.JaggedShare(std::max(o.leafy_edge_scatter_m, o.leafy_edge_scatter_px * px_m));
}

bool LeafyOutline(const MeasureOptions& o, const TangentFit& fit, double px_m,
                  bool straight_behind_nearer) {
  return o.leafy_edge_share > 0 && !straight_behind_nearer &&
         JaggedSilhouetteShare(o, fit, px_m) >= o.leafy_edge_share;
}

bool BarkConfirmsCloud(const Stem& part, const TangentFit& fit, const BarkDepth& cloud_bark) {
  // Both sides in three views at least and a quarter of them; or, where nearer stems hide a side
  // in many views (which cannot show both), half of the others: a sapling's crown seen past
  // nearer stems shows both in a few views among many.
  const bool two_sided_often =
      fit.rays > 0 && fit.two_sided_views >= 3 &&
      (fit.two_sided_views >= fit.tried_views / 4 || 2 * fit.two_sided_views >= fit.open_views);
  return !fit.ok && !part.weak_support && two_sided_often && cloud_bark.ok &&
         !cloud_bark.at_search_end;
}

BarkDepth CheckFitOnBark(const BarkDepthOptions& o, const TangentOptions& t,
                         const TangentViews& views, double breast_z, TangentFit* fit,
                         const BarkDepth* measured) {
  if (!fit->ok) return {};
  const BarkDepth bark =
      measured ? *measured : MeasureBarkDepth(o, t, views, fit->centre, fit->radius_m, breast_z);
  if (bark.pairs >= o.min_pairs && (bark.peak_ncc < o.min_surface_ncc || bark.at_search_end)) {
    // Views warped through the circle do not line up within reach of it: its inside is no one
    // stem's bark (two stems and the gap between them, a shrub, a stem and what lies behind it),
    // or the silhouettes put it far from the bark they enclose.
    spdlog::debug("stems: ({:.2f}, {:.2f}) r {:.3f}: no bark lines up on the fit (ncc {:.2f}{})",
                  fit->centre.x(), fit->centre.y(), fit->radius_m, bark.peak_ncc,
                  bark.at_search_end ? " at the end of the search" : "");
    fit->ok = false;
  }
  return bark;
}

bool OutlineOutweighsPlainBark(const MeasureOptions& o, const TangentFit& fit,
                               const BarkDepth& bark, const Eigen::Vector2d& cloud_centre,
                               double cloud_radius_m, double px_m) {
  const Eigen::Vector2d across = Eigen::Vector2d(-cloud_centre.y(), cloud_centre.x()).normalized();
  const bool where_the_cloud_is =
      std::abs((fit.centre - cloud_centre).dot(across)) <= cloud_radius_m;
  // Stereo's smear widens the cloud but leaves its face where the stem's is: an outline narrower
  // than the cloud by the smear has its face within the smear's depth of the cloud's. (Farther
  // off, the outline is of something else: a stem behind a smear where nothing stands.)
  const double face_gap_m =
      std::abs((fit.centre.norm() - fit.radius_m) - (cloud_centre.norm() - cloud_radius_m));
  const double smear_m =
      face_gap_m <= o.stems.max_depth_smear_m ? o.outline_over_bark_smear_m : 0.0;
  return fit.ok && where_the_cloud_is && !bark.ok && !bark.at_search_end &&
         bark.pairs >= o.bark_depth.min_pairs && bark.peak_ncc < o.bark_depth.min_surface_ncc &&
         fit.two_sided_views >= o.outline_over_bark_two_sided_share * fit.tried_views &&
         fit.rms_m < o.outline_over_bark_rms_px * px_m &&
         fit.radius_m <= (1 + o.outline_over_bark_cloud_share) * cloud_radius_m &&
         fit.radius_m >= (1 - o.outline_over_bark_cloud_share) * cloud_radius_m - smear_m;
}

bool WideFitLinesUpOnBark(const MeasureOptions& o, const TangentFit& fit, const BarkDepth& bark,
                          double cloud_radius_m, bool cloud_behind_nearer) {
  if (!(fit.radius_m > o.wide_fit_scale * cloud_radius_m)) return true;
  if (cloud_behind_nearer && bark.pairs < o.bark_depth.min_pairs) return true;
  return bark.pairs >= o.bark_depth.min_pairs && bark.peak_ncc >= o.wide_fit_min_bark_ncc;
}

void RefineWithTangentRays(const MeasureOptions& o, const PinholeCamera& bgr_camera,
                           const std::vector<StampedPose>& keyframes,
                           std::vector<cv::Mat> gray_full, const std::vector<cv::Mat>& bgr,
                           std::vector<Stem>* stems, std::vector<Stem> larger_cloud_only,
                           std::vector<Stem> voted, const CloudSurfaceAt& on_cloud_surface) {
  // Silhouettes at the video's own resolution where the front end kept it, else the working one.
  std::vector<cv::Mat> gray = std::move(gray_full);
  PinholeCamera camera = bgr_camera;
  if (!gray.empty() && !gray[0].empty()) {
    camera = bgr_camera.Scaled(static_cast<double>(gray[0].cols) / bgr_camera.width);
  } else {
    gray.assign(bgr.size(), cv::Mat());
    for (size_t k = 0; k < bgr.size(); ++k) {
      if (!bgr[k].empty()) cv::cvtColor(bgr[k], gray[k], cv::COLOR_BGR2GRAY);
    }
  }
  PrepareTangentImages(o.tangent, &gray);
  std::vector<Eigen::Vector3d> occluders;
  for (const Stem& s : *stems) {
    occluders.emplace_back(s.centre_xy.x(), s.centre_xy.y(), 0.5 * s.dbh_m);
  }
  const TangentViews views{&camera, &keyframes, &gray, &occluders};
  const TangentOptions topt =
      o.tangent.ForImageScale(static_cast<double>(camera.width) / bgr_camera.width);
  std::vector<Stem> kept;               // nearest first
  std::vector<Eigen::Vector3d> leaves;  // circles of the leafy outlines of the part in hand
  // The silhouettes' verdict on one stem, and the stem as then reported.
  // `outline_may_outweigh_bark`: for the cloud's parts; the larger cloud's stems alone rest on
  // the coarse points' width, too rough to confirm an outline the bark does not.
  auto refine_stem = [&](Stem s, bool outline_may_outweigh_bark) {
    const double breast_z = s.floor_z_m + o.stems.breast_height_m;
    // Views where something covers the bark are left out for a part of the cloud, whose surface
    // says a stem stands there; a stem the larger cloud alone saw has none, and its bark must
    // line up in every view that shows it (a sapling's leafy crown lines up in some).
    BarkDepthOptions bark_options = o.bark_depth;
    if (!outline_may_outweigh_bark) bark_options.max_hidden_view_share = 0;
    const double r0 = CloudRadius(s);
    auto on_bark = [&](const TangentFit& candidate) {
      TangentFit copy = candidate;
      CheckFitOnBark(bark_options, topt, views, breast_z, &copy);
      return copy.ok;
    };
    // The bark of the last circle FitTangentRays asked about: mostly the fit it returns, which
    // the check below would otherwise measure again.
    TangentFit last_asked;
    BarkDepth last_bark;
    auto bark_says = [&](const TangentFit& candidate) {
      last_asked = candidate;
      last_bark = MeasureBarkDepth(bark_options, topt, views, candidate.centre, candidate.radius_m,
                                   breast_z);
      return JudgeBark(bark_options, last_bark);
    };
    auto rim_says = [&](const TangentFit& wider, double inner_radius) {
      return JudgeBark(bark_options, MeasureRimBark(bark_options, topt, views, wider.centre,
                                                    wider.radius_m, inner_radius, breast_z));
    };
    TangentFit f =
        FitTangentRays(topt, views, s.centre_xy, r0, breast_z, on_bark, bark_says, rim_says);
    const bool asked =
        last_asked.ok && last_asked.centre == f.centre && last_asked.radius_m == f.radius_m;
    const double px_m = s.centre_xy.norm() / camera.fx;
    const double judged_px_m = JudgedPixelM(o, s.centre_xy.norm(), camera.fx);
    // Behind a nearer stem, the views that show the sides where the cloud's circle predicts them
    // (SideViewsAt; none where the circle is wider than the nearer stem or its support weak).
    auto cloud_side_views = [&] {
      const bool may_show = o.sides_past_nearer_min_views > 0 && !s.weak_support &&
                            NoWiderThanANearerStemItIsBehind(kept, s.centre_xy, r0);
      return may_show ? SideViewsAt(topt, views, s.centre_xy, r0, breast_z)
                      : std::array<int, 2>{0, 0};
    };
    // One side alone, seen past the nearer stem, stands where the cloud's circle does not show
    // both (ShowsSidesPastNearerStem, below).
    const bool on_face = HoldOnFaceBehindNearer(
        s, r0, kept, topt, views, breast_z, px_m, o.one_side_past_nearer_min_views,
        [&] { return !ShowsSidesPastNearerStem(o, s, r0, kept, cloud_side_views()); }, &f);
    const TangentFit outline = f;
    const BarkDepth bark =
        CheckFitOnBark(bark_options, topt, views, breast_z, &f, asked ? &last_bark : nullptr);
    if (!f.ok && outline_may_outweigh_bark &&
        OutlineOutweighsPlainBark(o, outline, bark, s.centre_xy, r0, judged_px_m)) {
      spdlog::debug(
          "stems: ({:.2f}, {:.2f}) r {:.3f}: its bark correlates nowhere (ncc {:.2f}), its outline "
          "stands (two-sided in {} of {} views)",
          f.centre.x(), f.centre.y(), f.radius_m, bark.peak_ncc, f.two_sided_views, f.tried_views);
      f = outline;
    }
    // The votes' circle and the outline's, from different edges, agree: the bark need not line
    // up, but it must correlate somewhere (BarkDepthOptions::min_surface_ncc): inside a leaf
    // clump's or a shrub's outline nothing does.
    // Each side seen in views of its own counts where the outline keeps to one circle within 2
    // px: past a nearer stem, a stem shows one side at a time.
    const int each_side_views = outline.ok && outline.rms_m < 2 * judged_px_m
                                    ? std::min(outline.SideViews(0), outline.SideViews(1))
                                    : 0;
    const bool agrees_with_votes =
        s.silhouette_votes > 0 && outline.ok &&
        FitAgreesWithVotes(o.votes, s.centre_xy, r0, outline.centre, outline.radius_m,
                           outline.two_sided_views, each_side_views) &&
        (f.ok || bark.peak_ncc >= o.bark_depth.min_surface_ncc);
    if (!f.ok && agrees_with_votes) {
      spdlog::debug(
          "stems: ({:.2f}, {:.2f}) r {:.3f}: the outline agrees with the silhouettes' votes ({} at "
          "r {:.3f}), the bark does not line up (ncc {:.2f})",
          outline.centre.x(), outline.centre.y(), outline.radius_m, s.silhouette_votes, r0,
          bark.peak_ncc);
      f = outline;
    }
    // (Not asked of a fit held on its face: the cloud saw a sliver of it, its width no bound.)
    if (f.ok && !on_face &&
        !WideFitLinesUpOnBark(o, f, bark, r0, InShadowOfNearerStem(kept, s.centre_xy))) {
      spdlog::debug(
          "stems: ({:.2f}, {:.2f}) fit r {:.3f} over r0 {:.3f}: its bark does not show it "
          "(ncc {:.2f}, {} pairs)",
          s.centre_xy.x(), s.centre_xy.y(), f.radius_m, r0, bark.peak_ncc, bark.pairs);
      f.ok = false;
    }
    spdlog::debug(
        "tangent fit ({:.2f}, {:.2f}): ok {} r {:.3f} r0 {:.3f} rays {} views {} two-sided {} of "
        "{} tried, rms {:.1f} mm, at ({:.3f}, {:.3f})",
        s.centre_xy.x(), s.centre_xy.y(), f.ok, f.radius_m, r0, f.rays, f.views, f.two_sided_views,
        f.tried_views, 1000 * f.rms_m, f.centre.x(), f.centre.y());
    s.evidence = {f.tried_views,
                  f.two_sided_views,
                  f.ok ? f.rms_m / px_m : 0.0,
                  bark.pairs,
                  bark.peak_ncc,
                  bark.ok ? bark.shift_m : 0.0,
                  JaggedSilhouetteShare(o, f, px_m),
                  f.ok ? std::min(f.SideViews(0), f.SideViews(1)) : 0,
                  SideViewsClearOfNearerStems(topt, views, f, breast_z)};
    // Held on its face, the sides seen apart measure it: they bound its width from both sides
    // and the face its range, where the cloud saw a sliver of it (its width no check).
    auto part_lines_up_on_bark = [&] {
      return MeasureBarkDepth(bark_options, topt, views, s.centre_xy, r0, breast_z).ok;
    };
    SilhouetteVerdict verdict =
        on_face && f.ok ? SilhouetteVerdict::kUse
                        : JudgeSilhouetteFit(o, s, f, judged_px_m, bark.ok, part_lines_up_on_bark);
    if (verdict == SilhouetteVerdict::kDrop && o.keep_bark_confirmed_cloud && !f.ok && f.rays > 0) {
      const BarkDepth cloud_bark =
          MeasureBarkDepth(bark_options, topt, views, s.centre_xy, r0, breast_z);
      if (BarkConfirmsCloud(s, f, cloud_bark)) {
        spdlog::debug(
            "stems: ({:.2f}, {:.2f}) kept on its cloud: the bark lines up {:+.3f} m off it (ncc "
            "{:.2f}); both sides in {} of {} views, {} where no nearer stem hid a side",
            s.centre_xy.x(), s.centre_xy.y(), cloud_bark.shift_m, cloud_bark.peak_ncc,
            f.two_sided_views, f.tried_views, f.open_views);
        s.centre_xy += cloud_bark.shift_m * s.centre_xy.normalized();
        verdict = SilhouetteVerdict::kKeepCloud;
      }
    }
    if (verdict == SilhouetteVerdict::kKeepCloud && o.stems.dbh_method == DbhMethod::kTangent) {
      s.flags.Set(f.ok && f.two_sided_views < 3 ? StemFlag::kOneSided : StemFlag::kNoSilhouette);
    }
    // Stereo smears a stem toward what stands behind it on the same bearing, and the smear's
    // silhouettes are the nearer stem's: a part straight behind a listed stem (its centre within
    // that stem's width seen from the plot centre) stands only on silhouettes of its own.
    const bool behind_nearer = InShadowOfNearerStem(kept, f.ok ? f.centre : s.centre_xy);
    // A core stands alone only on clean silhouettes: both sides in a quarter of its views, on
    // one circle to a couple of pixels (a shrub's twigs give loose, one-sided edges). Straight
    // behind a nearer stem, each side in several views of its own, clear of its outline, will do
    // (SidesSeenApartPastNearer): the nearer stem hides one side from each end of the arm.
    // Elsewhere, a stem shows both sides in the same views, and sides only ever seen apart are
    // the edges of two things.
    const bool seen_apart = behind_nearer && SidesSeenApartPastNearer(
                                                 topt, f, s.evidence.clear_side_views, judged_px_m);
    s.evidence.sides_apart = seen_apart || on_face;
    const bool clean =
        (f.two_sided_views >= std::max(3, f.tried_views / 4) && f.rms_m < 2 * judged_px_m) ||
        seen_apart;
    const bool whole = clean && 2 * f.two_sided_views >= f.tried_views;
    const bool agrees = f.ok && std::abs(f.radius_m - r0) <= 0.2 * r0;
    const bool sharp = HasSharpSilhouettes(f, o.larger_cloud_only_max_rms_px, judged_px_m);
    // (Straight behind a listed stem, whether it shows past that stem decides, below.)
    if (f.ok && LeafyOutline(o, f, px_m, behind_nearer)) {
      spdlog::debug(
          "stems: ({:.2f}, {:.2f}) r {:.3f} dropped: {:.0f} % of its silhouettes are jagged, "
          "leaves",
          f.centre.x(), f.centre.y(), f.radius_m, 100 * JaggedSilhouetteShare(o, f, px_m));
      leaves.emplace_back(f.centre.x(), f.centre.y(), f.radius_m);
      return RefinedStem{SilhouetteVerdict::kDrop, std::move(s), false};
    }
    // (A fit held on its face stands on its own sides; once the bark vetoed it, it does not. Nor
    // does one that agrees with the votes' circle: two estimators from different edges.)
    if (behind_nearer && !(on_face && f.ok) && !agrees_with_votes &&
        !StandsOnItsOwnSilhouettes(o.tangent, f, judged_px_m)) {
      const std::array<int, 2> side_views = cloud_side_views();
      if (ShowsSidesPastNearerStem(o, s, r0, kept, side_views)) {
        spdlog::debug(
            "stems: ({:.2f}, {:.2f}) kept on its cloud: straight behind a listed stem, its sides "
            "show one at a time ({} and {} views)",
            s.centre_xy.x(), s.centre_xy.y(), side_views[0], side_views[1]);
        s.flags.Set(StemFlag::kOccluded);
        if (o.stems.dbh_method == DbhMethod::kTangent) s.flags.Set(StemFlag::kNoSilhouette);
        RefinedStem kept_on_cloud{SilhouetteVerdict::kKeepCloud, std::move(s)};
        kept_on_cloud.sides_past_nearer = true;
        kept_on_cloud.stem.evidence.sides_apart = true;
        return kept_on_cloud;
      }
      spdlog::debug(
          "stems: ({:.2f}, {:.2f}) dropped: straight behind a listed stem, no clean fit (fit ok {} "
          "at ({:.2f}, {:.2f}) r {:.3f} r0 {:.3f}, rays {}, sides {}/{}, clear {}/{}, rms {:.2f} "
          "px, "
          "bark ok {} ncc {:.2f})",
          s.centre_xy.x(), s.centre_xy.y(), f.ok, f.centre.x(), f.centre.y(), f.radius_m, r0,
          f.rays, f.ok ? f.SideViews(0) : 0, f.ok ? f.SideViews(1) : 0,
          s.evidence.clear_side_views[0], s.evidence.clear_side_views[1],
          f.ok ? f.rms_m / px_m : 0.0, bark.ok, bark.peak_ncc);
      return RefinedStem{SilhouetteVerdict::kDrop, std::move(s), false};
    }
    if (verdict != SilhouetteVerdict::kUse) {
      return RefinedStem{verdict, std::move(s), clean, whole, agrees, sharp, seen_apart};
    }
    // The silhouettes' views replace the cloud's count.
    s.flags.Clear(StemFlag::kFewViews);
    if (f.views < 4) s.flags.Set(StemFlag::kFewViews);
    if (s.depth_smeared) s.flags.Set(StemFlag::kDepthSmeared);
    // Over a quarter of the silhouettes beside a nearer stem: the width rests on the rest.
    if (4 * f.hidden_sides > 2 * f.tried_views || on_face) s.flags.Set(StemFlag::kOccluded);
    // Both silhouettes in too few views: the width rests on one side (a lower bound, mostly).
    if (f.two_sided_views < 3) s.flags.Set(StemFlag::kOneSided);
    // The bark places the circle along the line of sight better than the silhouettes' parallax.
    Eigen::Vector2d centre = f.centre;
    double radius = f.radius_m;
    if (bark.ok) {
      centre += bark.shift_m * centre.normalized();
      radius *= bark.scale;
    }
    s.dbh_tangent_m = 2 * radius;
    s.dbh_tangent_sd_m = 2 * f.radius_sd_m;
    // The silhouettes place the stem better than the cloud's depth does, whichever DBH is kept.
    s.fit_shift_m = (centre - s.centre_xy).norm();
    s.centre_xy = centre;
    s.n_views = f.views;
    s.arc_deg = f.arc_deg;
    if (o.stems.dbh_method == DbhMethod::kTangent) {
      s.dbh_m = s.dbh_tangent_m;
      s.dbh_sd_m = s.dbh_tangent_sd_m;
    }
    RefinedStem refined{verdict, std::move(s), clean, whole, agrees, sharp, seen_apart};
    refined.agrees_with_votes = agrees_with_votes;
    // For a stem without a part of its own (a part stands on its own surface): the bark must
    // line up on it, or be too little seen to say, as a sapling's leafy crown gives the cloud a
    // surface too, and its inside lines up nowhere.
    const bool bark_allows = bark.ok || bark.pairs < o.bark_depth.min_pairs;
    refined.on_cloud_surface = !outline_may_outweigh_bark && bark_allows && on_cloud_surface &&
                               on_cloud_surface(centre, radius);
    refined.whole_where_open =
        clean && bark.ok && f.open_views < f.tried_views && 2 * f.two_sided_views >= f.open_views;
    return refined;
  };
  auto refine = [&](Stem s) { return refine_stem(std::move(s), true); };
  const size_t n_larger_only = larger_cloud_only.size();
  PartOutcome total;
  // Nearest first (the detector's order): a farther stem's edge search then stops at the nearer
  // stems' fitted silhouettes rather than at the cloud's rougher outlines.
  for (size_t i = 0; i < stems->size(); ++i) {
    const size_t before = kept.size();
    const bool mixed_part_core = (*stems)[i].mixed_part_core;
    leaves.clear();
    const PartOutcome p = ResolvePart(o, std::move((*stems)[i]), refine, &kept);
    PlaceFittedOccluders(std::span(kept).subspan(before), leaves, i,
                         o.unfitted_parts_hide && !mixed_part_core, &occluders);
    total.fitted += p.fitted;
    total.from_cores += p.from_cores;
    total.dropped += p.dropped;
  }
  // Last, where no listed stem stands: a stem hidden for most of the turn that only the larger
  // cloud saw.
  const int hidden = AddLargerCloudOnlyStems(
      o, std::move(larger_cloud_only), [&](Stem s) { return refine_stem(std::move(s), false); },
      &kept, &occluders);
  const size_t n_voted = voted.size();
  const int from_votes = AddStemsWithoutPart(
      o, std::move(voted), {o.votes.min_gap_to_listed_m, true, o.votes.max_candidates},
      [&](Stem s) { return refine_stem(std::move(s), false); }, &kept, &occluders);
  BoundHiddenSides(o, camera, keyframes, gray, &kept);
  const int twice = DropStemsFittedTwice(o.min_bark_gap_m, &kept);
  spdlog::info(
      "stems: tangent rays fitted {} of {} stems ({} from the cores of parts) and {} of {} the "
      "larger cloud alone found, {} of {} places the silhouettes' votes gave; {} parts without "
      "silhouettes dropped, {} fitted onto another stem",
      total.fitted, stems->size(), total.from_cores, hidden, n_larger_only, from_votes, n_voted,
      total.dropped, twice);
  *stems = std::move(kept);
}

}  // namespace stemmap::stems
