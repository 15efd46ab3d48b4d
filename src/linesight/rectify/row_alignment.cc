#include "linesight/rectify/row_alignment.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/core/error.h"

namespace linesight {
namespace {

cv::Mat Grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

double Quantile(std::vector<double> values, double q) {
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * double(values.size())));
  std::nth_element(values.begin(), values.begin() + long(k), values.end());
  return values[k];
}

// Corners sit on whole pixels; the row offset of one match is refined to a fraction of a pixel by
// normalised cross-correlation of a 15x15 patch of the left image over the right image within
// +-2 px of the matched corner, with a parabola through the peak and its neighbours in y. Matches
// whose peak is weak (< 0.8) or on the search border are dropped.
std::optional<double> RefinedRowOffset(const cv::Mat& left, const cv::Mat& right, cv::Point2f l,
                                       cv::Point2f r) {
  constexpr int kRadius = 7, kSearch = 2;
  const cv::Point pl(cvRound(l.x), cvRound(l.y)), pr(cvRound(r.x), cvRound(r.y));
  const cv::Rect patch(pl.x - kRadius, pl.y - kRadius, 2 * kRadius + 1, 2 * kRadius + 1);
  const cv::Rect area(pr.x - kRadius - kSearch, pr.y - kRadius - kSearch,
                      2 * (kRadius + kSearch) + 1, 2 * (kRadius + kSearch) + 1);
  const cv::Rect image(0, 0, left.cols, left.rows);
  if ((patch & image) != patch || (area & image) != area) return std::nullopt;
  cv::Mat score;
  cv::matchTemplate(right(area), left(patch), score, cv::TM_CCOEFF_NORMED);
  double best = 0;
  cv::Point at;
  cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
  if (best < 0.8 || at.y == 0 || at.y == score.rows - 1) return std::nullopt;
  const double a = score.at<float>(at.y - 1, at.x), b = score.at<float>(at.y, at.x),
               c = score.at<float>(at.y + 1, at.x);
  const double curvature = a - 2 * b + c;
  const double sub = curvature < 0 ? 0.5 * (a - c) / curvature : 0.0;
  return double(pr.y + at.y - kSearch) + sub - double(pl.y);
}

}  // namespace

void RowAlignmentOptions::Check() const {
  CheckOption(max_features >= 50, "RowAlignmentOptions.max_features", max_features,
              "must be >= 50");
  CheckOption(max_row_offset_px > 0, "RowAlignmentOptions.max_row_offset_px", max_row_offset_px,
              "must be > 0 px");
  CheckOption(min_matches >= 5, "RowAlignmentOptions.min_matches", min_matches, "must be >= 5");
  CheckOption(good_px > 0, "RowAlignmentOptions.good_px", good_px, "must be > 0 px");
  CheckOption(recalibrate_px > good_px, "RowAlignmentOptions.recalibrate_px", recalibrate_px,
              "must be > good_px");
}

std::string VerdictName(RowAlignment::Verdict verdict) {
  switch (verdict) {
    case RowAlignment::Verdict::kGood:
      return "good";
    case RowAlignment::Verdict::kCheck:
      return "check";
    case RowAlignment::Verdict::kRecalibrate:
      return "recalibrate";
    case RowAlignment::Verdict::kNoVerdict:
      break;
  }
  return "none";
}

nlohmann::json RowAlignment::ToJson() const {
  nlohmann::json j = {{"verdict", VerdictName(verdict)}, {"matches", matches}};
  if (verdict == Verdict::kNoVerdict) {
    j["reason"] = reason;
  } else {
    j["median_abs_row_offset_px"] = median_abs_offset_px;
    j["median_row_offset_px"] = median_offset_px;
    j["p90_abs_row_offset_px"] = p90_abs_offset_px;
  }
  return j;
}

RowAlignment MeasureRowAlignment(const cv::Mat& left_rectified, const cv::Mat& right_rectified,
                                 const RowAlignmentOptions& options) {
  options.Check();
  if (left_rectified.empty() || left_rectified.size() != right_rectified.size()) {
    throw InputError(fmt::format(
        "row alignment needs two rectified images of one size, got {}x{} "
        "and {}x{}",
        left_rectified.cols, left_rectified.rows, right_rectified.cols, right_rectified.rows));
  }
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(options.max_features);
  std::vector<cv::KeyPoint> left_points, right_points;
  cv::Mat left_descriptors, right_descriptors;
  const cv::Mat left = Grey(left_rectified), right = Grey(right_rectified);
  orb->detectAndCompute(left, cv::noArray(), left_points, left_descriptors);
  orb->detectAndCompute(right, cv::noArray(), right_points, right_descriptors);
  RowAlignment result;
  std::vector<cv::DMatch> matches;
  if (!left_descriptors.empty() && !right_descriptors.empty()) {
    cv::BFMatcher(cv::NORM_HAMMING, /*crossCheck=*/true)
        .match(left_descriptors, right_descriptors, matches);
  }
  std::vector<double> offsets, magnitudes;
  for (const cv::DMatch& m : matches) {
    const cv::Point2f& l = left_points[size_t(m.queryIdx)].pt;
    const cv::Point2f& r = right_points[size_t(m.trainIdx)].pt;
    if (std::abs(r.y - l.y) > options.max_row_offset_px || r.x > l.x + 0.5f) continue;
    const std::optional<double> dy = RefinedRowOffset(left, right, l, r);
    if (!dy) continue;
    offsets.push_back(*dy);
    magnitudes.push_back(std::abs(*dy));
  }
  result.matches = static_cast<int>(offsets.size());
  if (result.matches < options.min_matches) {
    result.reason = fmt::format("{} consistent matches, {} needed (too little texture in view)",
                                result.matches, options.min_matches);
    return result;
  }
  result.median_offset_px = Quantile(offsets, 0.5);
  result.median_abs_offset_px = Quantile(magnitudes, 0.5);
  result.p90_abs_offset_px = Quantile(magnitudes, 0.9);
  result.verdict = result.median_abs_offset_px < options.good_px ? RowAlignment::Verdict::kGood
                   : result.median_abs_offset_px < options.recalibrate_px
                       ? RowAlignment::Verdict::kCheck
                       : RowAlignment::Verdict::kRecalibrate;
  return result;
}

}  // namespace linesight
