#include "linesight/ranging/obstacle_finder.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/ranging/thin_structures.h"

namespace linesight {

void ObstacleFinderOptions::Check() const {
  CheckOption(min_depth_m > 0.0, "ObstacleFinderOptions.min_depth_m", min_depth_m, "must be > 0");
  CheckOption(max_depth_m > min_depth_m, "ObstacleFinderOptions.max_depth_m", max_depth_m,
              "must exceed min_depth_m");
  CheckOption(min_width_m > 0.0, "ObstacleFinderOptions.min_width_m", min_width_m, "must be > 0");
  CheckOption(depth_band_relative > 0.0 && depth_band_relative <= 0.5,
              "ObstacleFinderOptions.depth_band_relative", depth_band_relative,
              "must be in (0, 0.5]");
  CheckOption(min_area_px >= 1, "ObstacleFinderOptions.min_area_px", min_area_px, "must be >= 1");
  CheckOption(merge_overlap > 0.0 && merge_overlap <= 1.0, "ObstacleFinderOptions.merge_overlap",
              merge_overlap, "must be in (0, 1]");
  CheckOption(merge_depth_log_ratio > 0.0, "ObstacleFinderOptions.merge_depth_log_ratio",
              merge_depth_log_ratio, "must be > 0");
}

std::vector<cv::Rect> FindObstacleRegions(const cv::Mat& disparity, const StereoGeometry& geometry,
                                          const ObstacleFinderOptions& options) {
  options.Check();
  CheckDisparityMap(disparity, "disparity");
  const DepthBands depth_bands(geometry, options.min_depth_m, options.max_depth_m,
                               options.depth_band_relative);
  const double band = depth_bands.width;
  // Band index of every pixel in the working range (-1 elsewhere).
  const cv::Mat band_of = depth_bands.Map(disparity);

  // Thick pixels: deep inside a body of at least min_width at its depth.
  ThinStructureOptions thin;
  thin.min_width_m = options.min_width_m;
  thin.depth_band_relative = options.depth_band_relative;
  thin.min_depth_m = options.min_depth_m;
  thin.max_depth_m = options.max_depth_m;
  const cv::Mat thick =
      BodyMask(disparity, geometry, cv::Rect(0, 0, disparity.cols, disparity.rows), thin, true);

  // Regions: connected thick pixels, grown back by the erosion radius over pixels of similar depth.
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(thick, labels, stats, centroids, 8, CV_32S);
  std::vector<cv::Rect> boxes;
  std::vector<int> box_bands, box_areas;  // median depth band and pixel count of each region
  for (int label = 1; label < count; ++label) {
    cv::Rect box(stats.at<int>(label, cv::CC_STAT_LEFT), stats.at<int>(label, cv::CC_STAT_TOP),
                 stats.at<int>(label, cv::CC_STAT_WIDTH), stats.at<int>(label, cv::CC_STAT_HEIGHT));
    // Median band of the region, to grow over its own surface only.
    std::vector<int> region_bands;
    for (int y = box.y; y < box.y + box.height; ++y) {
      for (int x = box.x; x < box.x + box.width; ++x) {
        if (labels.at<int>(y, x) == label) region_bands.push_back(band_of.at<int>(y, x));
      }
    }
    std::nth_element(region_bands.begin(), region_bands.begin() + region_bands.size() / 2,
                     region_bands.end());
    const int k = region_bands[region_bands.size() / 2];
    const double d_band = depth_bands.CentreDisparity(k);
    const int grow = int(std::ceil(0.5 * options.min_width_m * geometry.focal_px /
                                   geometry.DepthFromDisparity(d_band))) +
                     1;
    const cv::Rect outer = (box + cv::Size(2 * grow, 2 * grow) - cv::Point(grow, grow)) &
                           cv::Rect(0, 0, disparity.cols, disparity.rows);
    const cv::Mat region = labels(outer) == label;
    cv::Mat grown;
    cv::dilate(region, grown,
               cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * grow + 1, 2 * grow + 1}));
    cv::Mat same_surface;
    cv::inRange(band_of(outer), k - 3, k + 3, same_surface);
    grown &= same_surface;
    const cv::Rect grown_box = cv::boundingRect(grown) + outer.tl();
    const int area = cv::countNonZero(grown);
    if (area < options.min_area_px) continue;
    boxes.push_back(grown_box);
    box_bands.push_back(k);
    box_areas.push_back(area);
  }

  // Merge boxes that overlap a lot and lie at similar depths (one obstacle split into parts, e.g.
  // the two weights of a damper are not merged unless they overlap); the merged region keeps the
  // depth band of its larger part.
  const double merge_bands = options.merge_depth_log_ratio / band;
  bool merged = true;
  while (merged) {
    merged = false;
    for (size_t i = 0; i < boxes.size() && !merged; ++i) {
      for (size_t j = i + 1; j < boxes.size() && !merged; ++j) {
        const double overlap = (boxes[i] & boxes[j]).area();
        if (overlap > options.merge_overlap * std::min(boxes[i].area(), boxes[j].area()) &&
            std::abs(box_bands[i] - box_bands[j]) <= merge_bands) {
          boxes[i] |= boxes[j];
          if (box_areas[j] > box_areas[i]) box_bands[i] = box_bands[j];
          box_areas[i] += box_areas[j];
          boxes.erase(boxes.begin() + long(j));
          box_bands.erase(box_bands.begin() + long(j));
          box_areas.erase(box_areas.begin() + long(j));
          merged = true;
        }
      }
    }
  }
  return boxes;
}

std::vector<RangeResult> RangeAllObstacles(const cv::Mat& disparity, const StereoGeometry& geometry,
                                           const ObstacleFinderOptions& finder_options,
                                           const RangingOptions& ranging_options) {
  std::vector<RangeResult> results;
  for (const cv::Rect& box : FindObstacleRegions(disparity, geometry, finder_options)) {
    results.push_back(RangeObstacle(disparity, geometry, box, ranging_options));
  }
  std::stable_sort(results.begin(), results.end(), [](const RangeResult& a, const RangeResult& b) {
    if (a.ok() != b.ok()) return a.ok();
    return a.distance_m < b.distance_m;
  });
  return results;
}

}  // namespace linesight
