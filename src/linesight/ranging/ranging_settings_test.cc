#include "linesight/ranging/ranging_settings.h"

#include <cmath>

#include <gtest/gtest.h>

namespace linesight {
namespace {

// Both checks a RangingPipeline runs on its options.
void CheckPipelineOptions(const RangingPipelineOptions& options) {
  options.Check();
  options.ranging.Check();
}

TEST(RangingSettings, EveryKeyOfTheCommandLineIsInTheTable) {
  const std::vector<std::string> keys = {"near_percentile",
                                         "core_fraction",
                                         "silhouette_margin_x_px",
                                         "silhouette_margin_y_px",
                                         "fill_rejected_holes",
                                         "min_body_width_m",
                                         "largest_mode_without_bodies",
                                         "min_body_width_px",
                                         "smoothing_radius_px",
                                         "checked",
                                         "model_relative_sigma",
                                         "search_from_zero",
                                         "refine",
                                         "surface_disagreement_weight",
                                         "surface_band_relative",
                                         "surface_gradient_ratio",
                                         "surface_min_ncc",
                                         "surface_min_pixels",
                                         "surface_interior",
                                         "edge_min_rows",
                                         "edge_min_contrast",
                                         "edge_row_extension",
                                         "edge_max_slope",
                                         "edge_surface_plateau"};
  EXPECT_EQ(RangingSettingsTable().Keys(), keys);
  const std::string help = RangingSettingsTable().Help();
  for (const std::string& key : keys) EXPECT_NE(help.find("  " + key + " = "), std::string::npos);
  for (const auto& row : RangingSettingsTable().rows()) EXPECT_FALSE(row.doc.empty()) << row.key;
}

TEST(RangingSettings, KeysSetTheirMembers) {
  RangingPipelineOptions o;
  ApplyRangingSettings("--ranging",
                       {"near_percentile=0.95,silhouette_margin_x_px=2", "checked=0", "refine=0",
                        "surface_gradient_ratio=0", "surface_interior=0", "edge_min_rows=6",
                        "edge_max_slope=0.5", "surface_band_relative=0.02"},
                       &o);
  EXPECT_EQ(o.ranging.near_percentile, 0.95);
  EXPECT_EQ(o.ranging.silhouette_margin_x_px, 2);
  EXPECT_FALSE(o.range_on_checked_disparity);
  EXPECT_FALSE(o.refine_on_images);
  EXPECT_EQ(o.surface.gradient_ratio, 0.0);
  EXPECT_FALSE(o.surface.interior_only);
  EXPECT_EQ(o.edges.min_rows, 6);
  EXPECT_EQ(o.edges.max_slope, 0.5);
  EXPECT_EQ(o.ranging.surface_band_relative, 0.02);
  // Untouched settings keep their defaults.
  EXPECT_EQ(o.ranging.core_fraction, RangingPipelineOptions().ranging.core_fraction);
}

TEST(RangingSettings, ErrorsNameTheSettingAndWhatIsAccepted) {
  RangingPipelineOptions o;
  try {
    ApplyRangingSettings("--ranging", {"edge_min_rows=2.5"}, &o);
    FAIL() << "no throw";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(),
                 "--ranging 'edge_min_rows=2.5': expected a whole number in [1, 1000000]");
  }
  try {
    ApplyRangingSettings("--ranging", {"near=1"}, &o);
    FAIL() << "no throw";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key (valid: near_percentile, core_fraction"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ApplyRangingSettings("--ranging", {"checked"}, &o), UsageError);
}

// The table's ranges are those of the options' Check(): each closed end passes both, a value just
// beyond an end fails the table and Check() alike.
TEST(RangingSettings, RangesAgreeWithTheOptionsChecks) {
  for (const auto& row : RangingSettingsTable().rows()) {
    if (row.type == OptionType::kBool) continue;
    const bool whole = row.type == OptionType::kInt;
    for (const bool upper : {false, true}) {
      const double end = upper ? row.range.hi : row.range.lo;
      if (!std::isfinite(end) || std::abs(end) >= 1e6) continue;  // (no Check() bound there)
      const bool open = upper ? row.range.hi_open : row.range.lo_open;
      const double step = whole ? 1.0 : 1e-9 * std::max(1.0, std::abs(end));
      const double beyond = upper ? (open ? end : end + step) : (open ? end : end - step);
      RangingPipelineOptions o;
      EXPECT_FALSE(row.range.Contains(beyond)) << row.key;
      row.set(o, beyond);
      EXPECT_THROW(CheckPipelineOptions(o), OptionError) << row.key << " = " << beyond;
      if (!open) {
        RangingPipelineOptions at_end;
        row.set(at_end, end);
        EXPECT_NO_THROW(CheckPipelineOptions(at_end)) << row.key << " = " << end;
      }
    }
  }
}

}  // namespace
}  // namespace linesight
