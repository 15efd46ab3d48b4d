#include "linesight/eval/metrics.h"

#include <cmath>

#include <fmt/format.h>

#include "linesight/core/error.h"

namespace linesight {

namespace {

constexpr double kD1AbsolutePx = 3.0;     // KITTI D1: |e| > 3 px ...
constexpr double kD1RelativeToGt = 0.05;  // ... and |e| > 5 % of d_gt

double Percent(int64_t count, int64_t total) {
  return total > 0 ? 100.0 * static_cast<double>(count) / static_cast<double>(total) : 0.0;
}

std::string TypeName(const cv::Mat& m) {
  return fmt::format("depth {} with {} channel(s)", m.depth(), m.channels());
}

}  // namespace

std::string BadKey(double threshold, bool sparse) {
  return fmt::format("bad_{}{}", threshold, sparse ? "_sparse" : "");
}

nlohmann::json DisparityMetrics::ToJson() const {
  nlohmann::json json;
  json["evaluated"] = evaluated;
  json["estimated"] = estimated;
  json["density"] = density;
  for (size_t i = 0; i < kBadThresholds.size(); ++i) json[BadKey(kBadThresholds[i])] = bad[i];
  json["d1"] = d1;
  for (size_t i = 0; i < kBadThresholds.size(); ++i)
    json[BadKey(kBadThresholds[i], true)] = bad_sparse[i];
  json["d1_sparse"] = d1_sparse;
  json["avgerr"] = avgerr;
  json["rmse"] = rmse;
  return json;
}

DisparityMetrics DisparityMetrics::FromJson(const nlohmann::json& json) {
  DisparityMetrics m;
  m.evaluated = json.at("evaluated").get<int64_t>();
  m.estimated = json.at("estimated").get<int64_t>();
  m.density = json.at("density").get<double>();
  for (size_t i = 0; i < kBadThresholds.size(); ++i) {
    m.bad[i] = json.at(BadKey(kBadThresholds[i])).get<double>();
    m.bad_sparse[i] = json.at(BadKey(kBadThresholds[i], true)).get<double>();
  }
  m.d1 = json.at("d1").get<double>();
  m.d1_sparse = json.at("d1_sparse").get<double>();
  m.avgerr = json.at("avgerr").get<double>();
  m.rmse = json.at("rmse").get<double>();
  return m;
}

DisparityMetrics ComputeDisparityMetrics(const cv::Mat& disparity, const cv::Mat& ground_truth,
                                         const cv::Mat& mask) {
  if (disparity.type() != CV_32FC1) {
    throw InputError(fmt::format("disparity map must be single-channel float (CV_32FC1), got {}",
                                 TypeName(disparity)));
  }
  if (ground_truth.type() != CV_32FC1) {
    throw InputError(fmt::format("ground truth must be single-channel float (CV_32FC1), got {}",
                                 TypeName(ground_truth)));
  }
  if (disparity.size() != ground_truth.size()) {
    throw InputError(
        fmt::format("disparity map is {}x{} but the ground truth is {}x{} (expected the same size)",
                    disparity.cols, disparity.rows, ground_truth.cols, ground_truth.rows));
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != ground_truth.size())) {
    throw InputError(fmt::format("evaluation mask must be 8-bit single-channel {}x{}, got {}x{} {}",
                                 ground_truth.cols, ground_truth.rows, mask.cols, mask.rows,
                                 TypeName(mask)));
  }

  int64_t evaluated = 0, estimated = 0, d1_count = 0;
  std::array<int64_t, kBadThresholds.size()> bad_count{};
  double sum_abs = 0, sum_sq = 0;
  for (int y = 0; y < ground_truth.rows; ++y) {
    const float* d_row = disparity.ptr<float>(y);
    const float* gt_row = ground_truth.ptr<float>(y);
    const uint8_t* m_row = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = 0; x < ground_truth.cols; ++x) {
      if (m_row != nullptr && m_row[x] == 0) continue;
      const float gt = gt_row[x];
      if (!std::isfinite(gt)) continue;
      ++evaluated;
      const float d = d_row[x];
      if (!std::isfinite(d)) continue;
      ++estimated;
      const double error = std::abs(static_cast<double>(d) - static_cast<double>(gt));
      sum_abs += error;
      sum_sq += error * error;
      for (size_t i = 0; i < kBadThresholds.size(); ++i) bad_count[i] += error > kBadThresholds[i];
      d1_count +=
          error > kD1AbsolutePx && error > kD1RelativeToGt * std::abs(static_cast<double>(gt));
    }
  }

  DisparityMetrics metrics;
  metrics.evaluated = evaluated;
  metrics.estimated = estimated;
  metrics.density = Percent(estimated, evaluated);
  const int64_t missing = evaluated - estimated;
  for (size_t i = 0; i < kBadThresholds.size(); ++i) {
    metrics.bad[i] = Percent(bad_count[i] + missing, evaluated);
    metrics.bad_sparse[i] = Percent(bad_count[i], estimated);
  }
  metrics.d1 = Percent(d1_count + missing, evaluated);
  metrics.d1_sparse = Percent(d1_count, estimated);
  if (estimated > 0) {
    metrics.avgerr = sum_abs / static_cast<double>(estimated);
    metrics.rmse = std::sqrt(sum_sq / static_cast<double>(estimated));
  }
  return metrics;
}

std::map<std::string, DisparityMetrics> ComputeRegionMetrics(
    const cv::Mat& disparity, const cv::Mat& ground_truth,
    const std::map<std::string, cv::Mat>& masks) {
  std::map<std::string, DisparityMetrics> regions;
  for (const auto& [name, mask] : masks)
    regions[name] = ComputeDisparityMetrics(disparity, ground_truth, mask);
  return regions;
}

}  // namespace linesight
