#include <nlohmann/json.hpp>

#include "stemmap/stems/tangent.h"

namespace stemmap::stems {

void to_json(nlohmann::json& j, const TangentOptions& o) {
  j = {{"background_parallax_px", o.background_parallax_px},
       {"max_neighbour_offset", o.max_neighbour_offset},
       {"rows_half", o.rows_half},
       {"band_half_height_m", o.band_half_height_m},
       {"search_px", o.search_px},
       {"search_share", o.search_share},
       {"min_contrast", o.min_contrast},
       {"min_brightness_contrast", o.min_brightness_contrast},
       {"huber_m", o.huber_m},
       {"prior_share_of_distance", o.prior_share_of_distance},
       {"min_rays", o.min_rays},
       {"max_sideways_m", o.max_sideways_m},
       {"occluder_min_gap_m", o.occluder_min_gap_m},
       {"refits", o.refits},
       {"wide_start_scales", o.wide_start_scales},
       {"recheck_wider_scale", o.recheck_wider_scale},
       {"recheck_min_gain", o.recheck_min_gain},
       {"narrow_start_scales", o.narrow_start_scales},
       {"narrow_max_rms_px", o.narrow_max_rms_px},
       {"narrow_min_share", o.narrow_min_share},
       {"sideways_start_shifts", o.sideways_start_shifts},
       {"pooled_min_extra_rays", o.pooled_min_extra_rays},
       {"few_views_min_two_sided", o.few_views_min_two_sided},
       {"few_views_min_share", o.few_views_min_share},
       {"settle_few_views", o.settle_few_views},
       {"refine_on_brightness", o.refine_on_brightness},
       {"blur_sigma_px", o.blur_sigma_px}};
}

}  // namespace stemmap::stems
