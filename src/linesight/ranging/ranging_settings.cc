#include "linesight/ranging/ranging_settings.h"

namespace linesight {

namespace {

OptionTable<RangingPipelineOptions> MakeRangingSettingsTable() {
  using O = RangingPipelineOptions;
  using R = OptionRange;
  OptionTable<O> t;
  t.Add("near_percentile", OptionField(&O::ranging, &RangingOptions::near_percentile),
        R::Closed(0.5, 1), "percentile of the smoothed disparities taken as the nearest surface")
      .Add("core_fraction", OptionField(&O::ranging, &RangingOptions::core_fraction),
           R::OpenClosed(0, 1), "mode support is counted over this central fraction of the ROI")
      .Add("silhouette_margin_x_px",
           OptionField(&O::ranging, &RangingOptions::silhouette_margin_x_px), R::Closed(0, 15),
           "margin inside the mode's outline left out of the percentile, left and right (px)")
      .Add("silhouette_margin_y_px",
           OptionField(&O::ranging, &RangingOptions::silhouette_margin_y_px), R::Closed(0, 15),
           "margin inside the mode's outline left out of the percentile, above and below (px)")
      .Add("fill_rejected_holes", OptionField(&O::ranging, &RangingOptions::fill_rejected_holes),
           "enclosed holes of rejected pixels are not outline")
      .Add("min_body_width_m", OptionField(&O::ranging, &RangingOptions::min_body_width_m),
           R::AtLeast(0), "narrower structures are thin and dropped before the mode (m; 0 = off)")
      .Add("largest_mode_without_bodies",
           OptionField(&O::ranging, &RangingOptions::largest_mode_without_bodies),
           "with no body left, the mode with the most support instead of the nearest")
      .Add("min_body_width_px", OptionField(&O::ranging, &RangingOptions::min_body_width_px),
           R::Closed(0, 64), "narrower structures are thin, in pixels (0 = off)")
      .Add("smoothing_radius_px", OptionField(&O::ranging, &RangingOptions::smoothing_radius_px),
           R::Closed(0, 15), "median radius before the percentile (px)")
      .Add("checked", OptionField(&O::range_on_checked_disparity),
           "range on the matcher's checked disparities only")
      .Add("model_relative_sigma", OptionField(&O::model_relative_sigma), R::ClosedOpen(0, 0.5),
           "relative sigma added for calibration and matcher bias")
      .Add("search_from_zero", OptionField(&O::search_from_zero), "match from disparity 0")
      .Add("refine", OptionField(&O::refine_on_images),
           "measure the nearest surface again on the images (surface fit, silhouette edges) and "
           "fuse the readings")
      .Add("surface_disagreement_weight", OptionField(&O::surface_disagreement_weight),
           R::Closed(0, 4), "weight of the readings' disagreement in sigma_d")
      .Add("surface_band_relative",
           OptionField(&O::ranging, &RangingOptions::surface_band_relative), R::OpenClosed(0, 0.2),
           "the surface: pixels within this relative depth of the nearest point")
      .Add("surface_gradient_ratio",
           OptionField(&O::surface, &SurfaceRefinementOptions::gradient_ratio), R::Closed(0, 100),
           "fit pixels with |dI/dy| <= ratio * |dI/dx| (1 = 45 deg, 0 = every pixel)")
      .Add("surface_min_ncc", OptionField(&O::surface, &SurfaceRefinementOptions::min_ncc),
           R::ClosedOpen(-1, 1), "correlation gate of the fit")
      .Add("surface_min_pixels", OptionField(&O::surface, &SurfaceRefinementOptions::min_pixels),
           R::Closed(3, 1000000), "fewest clean pixels for the fit to set the distance")
      .Add("surface_interior", OptionField(&O::surface, &SurfaceRefinementOptions::interior_only),
           "fit only pixels whose four neighbours are on the surface")
      .Add("edge_min_rows", OptionField(&O::edges, &EdgeDisparityOptions::min_rows),
           R::Closed(1, 1000000), "edge rows per end")
      .Add("edge_min_contrast", OptionField(&O::edges, &EdgeDisparityOptions::min_contrast),
           R::Above(0), "grey levels between the plateaus beside an edge")
      .Add("edge_row_extension", OptionField(&O::edges, &EdgeDisparityOptions::row_extension_px),
           R::Closed(0, 32), "rows beyond the surface searched for edges")
      .Add("edge_max_slope", OptionField(&O::edges, &EdgeDisparityOptions::max_slope), R::Above(0),
           "largest |dx/dy| of an edge")
      .Add("edge_surface_plateau",
           OptionField(&O::edges, &EdgeDisparityOptions::surface_plateau_px), R::Closed(1, 16),
           "flat pixels required on the surface's side of an edge");
  return t;
}

}  // namespace

const OptionTable<RangingPipelineOptions>& RangingSettingsTable() {
  static const OptionTable<RangingPipelineOptions> table = MakeRangingSettingsTable();
  return table;
}

void ApplyRangingSettings(std::string_view flag, const std::vector<std::string>& entries,
                          RangingPipelineOptions* options) {
  RangingSettingsTable().Apply(flag, ParseKeyValues(flag, entries), options);
}

nlohmann::json RangingChainSettings(const RangingPipeline& pipeline) {
  const DisparityRange range = pipeline.disparity_range();
  return {{"method", pipeline.method()},
          {"matcher", pipeline.matcher().Settings()},
          {"ranging_settings", RangingSettingsTable().ToJson(pipeline.options())},
          {"disparity_range", {range.min_disparity, range.max_disparity()}}};
}

}  // namespace linesight
