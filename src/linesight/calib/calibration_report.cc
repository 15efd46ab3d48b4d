#include "linesight/calib/calibration_report.h"

#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include <ceres/ceres.h>
#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "linesight/calib/calib_costs.h"
#include "linesight/core/error.h"

namespace linesight::calib {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ReprojectionError2(const CameraIntrinsics& camera, const Pose& camera_from_board,
                          const Eigen::Vector3d& board_point, const Eigen::Vector2d& observed) {
  const Eigen::Vector3d p = camera_from_board.Apply(board_point);
  double pixel[2];
  Project(camera.params.data(), p.data(), pixel);
  return (Eigen::Vector2d(pixel[0], pixel[1]) - observed).squaredNorm();
}

// Squared reprojection errors of one view of one camera; pose may be absent (then nothing is
// added).
void AccumulateView(const CameraIntrinsics& camera, const std::optional<Pose>& pose,
                    const BoardGeometry& board, const ViewObservations& view, double* sum2,
                    int* count) {
  if (!pose || view.empty()) return;
  for (size_t k = 0; k < view.ids.size(); ++k) {
    *sum2 += ReprojectionError2(camera, *pose, board.points[view.ids[k]], view.pixels[k]);
    ++*count;
  }
}

std::optional<Pose> RightPose(const StereoObservations& obs, const StereoCalibrationResult& est,
                              size_t v) {
  if (est.left_from_board[v] && !obs.right[v].empty())
    return est.right_from_left * *est.left_from_board[v];
  return est.right_only_from_board[v];
}

std::string MatrixYaml(const cv::Mat& m) {
  cv::Mat d;
  m.convertTo(d, CV_64F);
  std::ostringstream out;
  out << "  rows: " << d.rows << "\n  cols: " << d.cols << "\n  data: [";
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c)
      out << (r || c ? ", " : "") << fmt::format("{:.12g}", d.at<double>(r, c));
  out << "]\n";
  return out.str();
}

nlohmann::json IntrinsicsJson(const CameraIntrinsics& c, const DistortionModel& model) {
  nlohmann::json j;
  j["fx"] = c.fx();
  j["fy"] = c.fy();
  j["cx"] = c.cx();
  j["cy"] = c.cy();
  std::vector<double> d;
  for (int i = 0; i < model.OpenCVCount(); ++i) d.push_back(c.params[kK1 + i]);
  j["distortion"] = d;
  return j;
}

nlohmann::json StddevJson(const std::array<double, kNumIntrinsics>& s,
                          const DistortionModel& model) {
  nlohmann::json j;
  j["fx"] = s[kFx];
  j["fy"] = s[kFy];
  j["cx"] = s[kCx];
  j["cy"] = s[kCy];
  std::vector<double> d;
  for (int i = 0; i < model.OpenCVCount(); ++i) d.push_back(s[kK1 + i]);
  j["distortion"] = d;
  return j;
}

nlohmann::json NullableNumber(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

// The observations with the board as the estimate models it (bent by recon, else as given).
StereoObservations OnEstimatedBoard(const StereoObservations& obs,
                                    const StereoCalibrationResult& est) {
  if (est.board_bend == BoardBend{}) return obs;
  StereoObservations bent = obs;
  bent.board = BendBoard(obs.board, est.board_bend);
  return bent;
}

}  // namespace

ReprojectionCovariance ComputeReprojectionCovariance(const StereoObservations& observations,
                                                     const StereoCalibrationResult& estimate) {
  const StereoObservations obs = OnEstimatedBoard(observations, estimate);
  StereoCalibrationResult at = estimate;  // the problem needs mutable parameter blocks
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  std::vector<double*> blocks = {at.left.params.data(), at.right.params.data(),
                                 at.right_from_left.params.data()};
  for (double* b : {blocks[0], blocks[1]}) problem.AddParameterBlock(b, kNumIntrinsics);
  problem.AddParameterBlock(blocks[2], kPoseSize);
  int residuals = 0;
  for (size_t v = 0; v < obs.size(); ++v) {
    const ViewObservations& left = obs.left[v];
    const ViewObservations& right = obs.right[v];
    if (at.left_from_board[v] && !left.empty()) {
      double* pose = at.left_from_board[v]->params.data();
      blocks.push_back(pose);
      for (size_t k = 0; k < left.ids.size(); ++k, residuals += 2) {
        problem.AddResidualBlock(
            detail::ReprojectionResidual::Create(left.pixels[k], obs.board.points[left.ids[k]]),
            nullptr, blocks[0], pose);
      }
      for (size_t k = 0; k < right.ids.size(); ++k, residuals += 2) {
        problem.AddResidualBlock(detail::StereoReprojectionResidual::Create(
                                     right.pixels[k], obs.board.points[right.ids[k]]),
                                 nullptr, blocks[1], pose, blocks[2]);
      }
    } else if (at.right_only_from_board[v] && !right.empty()) {
      double* pose = at.right_only_from_board[v]->params.data();
      blocks.push_back(pose);
      for (size_t k = 0; k < right.ids.size(); ++k, residuals += 2) {
        problem.AddResidualBlock(
            detail::ReprojectionResidual::Create(right.pixels[k], obs.board.points[right.ids[k]]),
            nullptr, blocks[1], pose);
      }
    }
  }
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = blocks;
  double cost = 0;
  std::vector<double> residual_values;
  ceres::CRSMatrix crs;
  problem.Evaluate(evaluate, &cost, &residual_values, nullptr, &crs);
  // Free columns: every column except the fixed intrinsics of both cameras.
  const std::vector<int> fixed = estimate.distortion.FixedIndices();
  std::vector<int> column_of(crs.num_cols, -1);
  int free_count = 0;
  for (int c = 0; c < crs.num_cols; ++c) {
    const bool is_fixed = c < 2 * kNumIntrinsics &&
                          std::find(fixed.begin(), fixed.end(), c % kNumIntrinsics) != fixed.end();
    if (!is_fixed) column_of[c] = free_count++;
  }
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(crs.num_rows, free_count);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i) {
      if (column_of[crs.cols[i]] >= 0) jacobian(r, column_of[crs.cols[i]]) = crs.values[i];
    }
  }
  ReprojectionCovariance out;
  out.residual_count = residuals;
  out.parameter_count = free_count;
  out.residual_variance = residuals > free_count ? 2.0 * cost / (residuals - free_count) : kNaN;
  out.left.setZero();
  out.right.setZero();
  out.right_from_left.setZero();
  const Eigen::MatrixXd information = jacobian.transpose() * jacobian;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(information);
  if (ldlt.info() != Eigen::Success) return out;
  // Only the first columns (cameras + stereo) are needed: solve for those unit vectors.
  const int wanted = column_of[2 * kNumIntrinsics + kPoseSize - 1] + 1;
  const Eigen::MatrixXd inverse_columns = ldlt.solve(Eigen::MatrixXd::Identity(free_count, wanted));
  if (!inverse_columns.allFinite()) return out;
  const auto fill = [&](int first_ambient, int size, auto* block) {
    for (int a = 0; a < size; ++a) {
      for (int b = 0; b < size; ++b) {
        const int ca = column_of[first_ambient + a], cb = column_of[first_ambient + b];
        (*block)(a, b) = (ca >= 0 && cb >= 0) ? inverse_columns(ca, cb) : 0.0;
      }
    }
  };
  fill(0, kNumIntrinsics, &out.left);
  fill(kNumIntrinsics, kNumIntrinsics, &out.right);
  fill(2 * kNumIntrinsics, kPoseSize, &out.right_from_left);
  out.valid = out.left.diagonal().minCoeff() >= 0 && out.right.diagonal().minCoeff() >= 0 &&
              out.right_from_left.diagonal().minCoeff() > 0;
  return out;
}

StereoCalibration MakeStereoCalibration(const StereoCalibrationResult& est, cv::Size image_size) {
  StereoCalibration calib;
  calib.image_size = image_size;
  const int count = est.distortion.OpenCVCount();
  calib.M1 = est.left.CameraMatrix();
  calib.D1 = est.left.Distortion(count);
  calib.M2 = est.right.CameraMatrix();
  calib.D2 = est.right.Distortion(count);
  calib.R = est.right_from_left.RotationMat();
  calib.T = est.right_from_left.TranslationMat();
  const double* t = calib.T.ptr<double>();
  const cv::Mat skew = (cv::Mat_<double>(3, 3) << 0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  calib.E = skew * calib.R;
  calib.F = calib.M2.inv().t() * calib.E * calib.M1.inv();
  calib.F /= calib.F.at<double>(2, 2);
  cv::stereoRectify(calib.M1, calib.D1, calib.M2, calib.D2, image_size, calib.R, calib.T, calib.R1,
                    calib.R2, calib.P1, calib.P2, calib.Q, cv::CALIB_ZERO_DISPARITY, 0, image_size);
  return calib;
}

double StereoRms(const StereoObservations& observations, const StereoCalibrationResult& est) {
  const StereoObservations obs = OnEstimatedBoard(observations, est);
  double sum2 = 0;
  int count = 0;
  for (size_t v = 0; v < obs.size(); ++v) {
    if (!obs.IsPair(v) || !est.left_from_board[v]) continue;
    AccumulateView(est.left, est.left_from_board[v], obs.board, obs.left[v], &sum2, &count);
    AccumulateView(est.right, RightPose(obs, est, v), obs.board, obs.right[v], &sum2, &count);
  }
  return count ? std::sqrt(sum2 / count) : kNaN;
}

CalibrationReport EvaluateCalibration(const StereoObservations& observations,
                                      const StereoCalibrationResult& est) {
  const StereoObservations obs = OnEstimatedBoard(observations, est);
  CalibrationReport report;
  double left_sum = 0, right_sum = 0;
  int left_count = 0, right_count = 0;
  for (size_t v = 0; v < obs.size(); ++v) {
    double s = 0;
    int n = 0;
    AccumulateView(est.left, est.left_from_board[v], obs.board, obs.left[v], &s, &n);
    report.left_view_rms_px.push_back(n ? std::sqrt(s / n) : kNaN);
    left_sum += s;
    left_count += n;
    s = 0;
    n = 0;
    AccumulateView(est.right, RightPose(obs, est, v), obs.board, obs.right[v], &s, &n);
    report.right_view_rms_px.push_back(n ? std::sqrt(s / n) : kNaN);
    right_sum += s;
    right_count += n;
  }
  report.left_rms_px = left_count ? std::sqrt(left_sum / left_count) : kNaN;
  report.right_rms_px = right_count ? std::sqrt(right_sum / right_count) : kNaN;
  report.stereo_rms_px = StereoRms(observations, est);
  report.calibration = MakeStereoCalibration(est, obs.image_size);
  const StereoCalibration& calib = report.calibration;

  // Epipolar error after rectification and the reconstruction error, over corners seen in both
  // images.
  double dy_sum = 0;
  double distance_sum2 = 0, true_distance_sum = 0;
  for (size_t v = 0; v < obs.size(); ++v) {
    if (!obs.IsPair(v)) continue;
    std::map<int, Eigen::Vector2d> right_by_id;
    for (size_t k = 0; k < obs.right[v].ids.size(); ++k)
      right_by_id[obs.right[v].ids[k]] = obs.right[v].pixels[k];
    std::vector<cv::Point2d> left_pixels, right_pixels;
    std::vector<int> ids;
    for (size_t k = 0; k < obs.left[v].ids.size(); ++k) {
      const auto it = right_by_id.find(obs.left[v].ids[k]);
      if (it == right_by_id.end()) continue;
      ids.push_back(obs.left[v].ids[k]);
      left_pixels.emplace_back(obs.left[v].pixels[k].x(), obs.left[v].pixels[k].y());
      right_pixels.emplace_back(it->second.x(), it->second.y());
    }
    if (ids.empty()) continue;
    std::vector<cv::Point2d> left_rectified, right_rectified;
    cv::undistortPoints(left_pixels, left_rectified, calib.M1, calib.D1, calib.R1, calib.P1);
    cv::undistortPoints(right_pixels, right_rectified, calib.M2, calib.D2, calib.R2, calib.P2);
    std::map<int, Eigen::Vector3d> triangulated;
    for (size_t k = 0; k < ids.size(); ++k) {
      dy_sum += std::abs(left_rectified[k].y - right_rectified[k].y);
      ++report.epipolar_points;
      const double lp[2] = {left_pixels[k].x, left_pixels[k].y};
      const double rp[2] = {right_pixels[k].x, right_pixels[k].y};
      Eigen::Vector2d ln, rn;
      if (!Unproject(est.left.params.data(), lp, ln.data(), 1e-6) ||
          !Unproject(est.right.params.data(), rp, rn.data(), 1e-6)) {
        continue;
      }
      triangulated[ids[k]] = TriangulateMidpoint(ln, rn, est.right_from_left);
    }
    for (const AdjacentPair& pair : obs.board.adjacent) {
      const auto a = triangulated.find(pair.a);
      const auto b = triangulated.find(pair.b);
      if (a == triangulated.end() || b == triangulated.end()) continue;
      const double error = (a->second - b->second).norm() - pair.distance_m;
      distance_sum2 += error * error;
      true_distance_sum += pair.distance_m;
      ++report.reconstruction_pairs;
    }
  }
  report.epipolar_mean_abs_dy_px = report.epipolar_points ? dy_sum / report.epipolar_points : kNaN;
  if (report.reconstruction_pairs) {
    report.reconstruction_rmse_m = std::sqrt(distance_sum2 / report.reconstruction_pairs);
    report.reconstruction_percent =
        100.0 * report.reconstruction_rmse_m / (true_distance_sum / report.reconstruction_pairs);
  }

  const ReprojectionCovariance covariance = ComputeReprojectionCovariance(observations, est);
  report.stddev_valid = covariance.valid;
  for (int i = 0; i < kNumIntrinsics; ++i) {
    report.left_stddev[i] =
        std::sqrt(std::max(0.0, covariance.residual_variance * covariance.left(i, i)));
    report.right_stddev[i] =
        std::sqrt(std::max(0.0, covariance.residual_variance * covariance.right(i, i)));
  }
  for (int i = 0; i < kPoseSize; ++i) {
    report.right_from_left_stddev[i] =
        std::sqrt(std::max(0.0, covariance.residual_variance * covariance.right_from_left(i, i)));
  }
  return report;
}

std::string RosCameraInfoYaml(const std::string& camera_name, cv::Size image_size,
                              const cv::Mat& camera_matrix, const cv::Mat& distortion,
                              const cv::Mat& rectification, const cv::Mat& projection) {
  std::ostringstream out;
  out << "image_width: " << image_size.width << "\n";
  out << "image_height: " << image_size.height << "\n";
  out << "camera_name: " << camera_name << "\n";
  out << "camera_matrix:\n" << MatrixYaml(camera_matrix);
  out << "distortion_model: " << (distortion.total() > 5 ? "rational_polynomial" : "plumb_bob")
      << "\n";
  out << "distortion_coefficients:\n" << MatrixYaml(distortion.reshape(1, 1));
  out << "rectification_matrix:\n" << MatrixYaml(rectification);
  out << "projection_matrix:\n" << MatrixYaml(projection);
  return out.str();
}

nlohmann::json ReportToJson(const StereoDetections& detections, const StereoCalibrationResult& est,
                            const CalibrationReport& report) {
  nlohmann::json j;
  j["method"] = MethodName(est.method);
  j["image_size"] = {detections.image_size.width, detections.image_size.height};
  j["views"] = {{"pairs", detections.pairs.size()},
                {"left_found", detections.LeftCount()},
                {"right_found", detections.RightCount()},
                {"both_found", detections.BothCount()}};
  nlohmann::json per_view = nlohmann::json::array();
  for (size_t v = 0; v < detections.pairs.size(); ++v) {
    const PairDetection& p = detections.pairs[v];
    nlohmann::json item;
    item["left"] = p.left_path.string();
    item["right"] = p.right_path.string();
    item["left_found"] = p.left.found;
    item["right_found"] = p.right.found;
    if (!p.left.found) item["left_reason"] = p.left.reason;
    if (!p.right.found) item["right_reason"] = p.right.reason;
    item["used_for"] = p.left.found && p.right.found ? "stereo + both intrinsics"
                       : p.left.found                ? "left intrinsics only"
                       : p.right.found               ? "right intrinsics only"
                                                     : "rejected";
    item["left_rms_px"] = NullableNumber(report.left_view_rms_px[v]);
    item["right_rms_px"] = NullableNumber(report.right_view_rms_px[v]);
    per_view.push_back(item);
  }
  j["per_view"] = per_view;
  j["left"] = IntrinsicsJson(est.left, est.distortion);
  j["right"] = IntrinsicsJson(est.right, est.distortion);
  j["right_from_left"] = {{"rotation_angle_axis_rad",
                           {est.right_from_left.params[0], est.right_from_left.params[1],
                            est.right_from_left.params[2]}},
                          {"translation_m",
                           {est.right_from_left.params[3], est.right_from_left.params[4],
                            est.right_from_left.params[5]}},
                          {"baseline_m", est.right_from_left.Translation().norm()}};
  // b0 b1 b2 of BendBoard: sag (board units) at u = ±1, v = ±1 and the twist; zero = flat board.
  j["board_bend"] = {est.board_bend[0], est.board_bend[1], est.board_bend[2]};
  j["rms_px"] = {{"left", report.left_rms_px},
                 {"right", report.right_rms_px},
                 {"stereo", report.stereo_rms_px}};
  if (est.method_reported_rms >= 0) j["rms_px"]["method_reported"] = est.method_reported_rms;
  j["epipolar_error_after_rectification_px"] = {
      {"mean_abs_dy", NullableNumber(report.epipolar_mean_abs_dy_px)},
      {"points", report.epipolar_points}};
  j["reconstruction_error"] = {{"adjacent_pairs", report.reconstruction_pairs},
                               {"rmse_m", report.reconstruction_rmse_m},
                               {"rmse_mm", 1000.0 * report.reconstruction_rmse_m},
                               {"percent_of_square", report.reconstruction_percent}};
  j["stddev"] = {{"valid", report.stddev_valid},
                 {"left", StddevJson(report.left_stddev, est.distortion)},
                 {"right", StddevJson(report.right_stddev, est.distortion)},
                 {"right_from_left",
                  {{"rotation_angle_axis_rad",
                    {report.right_from_left_stddev[0], report.right_from_left_stddev[1],
                     report.right_from_left_stddev[2]}},
                   {"translation_m",
                    {report.right_from_left_stddev[3], report.right_from_left_stddev[4],
                     report.right_from_left_stddev[5]}}}}};
  j["rectified"] = {{"focal_px", report.calibration.P1.at<double>(0, 0)},
                    {"baseline_m", -report.calibration.P2.at<double>(0, 3) /
                                       report.calibration.P2.at<double>(0, 0)}};
  return j;
}

cv::Mat CoverageImage(const StereoObservations& obs) {
  const cv::Size size = obs.image_size;
  const int gap = 10;
  cv::Mat canvas(size.height, 2 * size.width + gap, CV_8UC3, cv::Scalar(255, 255, 255));
  canvas.colRange(size.width, size.width + gap).setTo(cv::Scalar(128, 128, 128));
  for (size_t v = 0; v < obs.size(); ++v) {
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<int>((v * 37) % 180), 220, 200)), bgr;
    cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
    const cv::Scalar colour(c[0], c[1], c[2]);
    for (int side = 0; side < 2; ++side) {
      const ViewObservations& view = side == 0 ? obs.left[v] : obs.right[v];
      if (view.empty()) continue;
      const cv::Point2d offset(side * (size.width + gap), 0);
      std::vector<cv::Point> hull_input;
      for (const auto& p : view.pixels) {
        const cv::Point2d q(p.x() + offset.x, p.y());
        cv::circle(canvas, cv::Point(cvRound(q.x), cvRound(q.y)), 3, colour, cv::FILLED,
                   cv::LINE_AA);
        hull_input.emplace_back(cvRound(q.x), cvRound(q.y));
      }
      std::vector<cv::Point> hull;
      cv::convexHull(hull_input, hull);
      cv::polylines(canvas, hull, true, colour, 1, cv::LINE_AA);
    }
  }
  cv::putText(canvas, "left", {10, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.8, cv::Scalar(0, 0, 0), 2);
  cv::putText(canvas, "right", {size.width + gap + 10, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.8,
              cv::Scalar(0, 0, 0), 2);
  return canvas;
}

std::string PerViewRmsSvg(const CalibrationReport& report) {
  const size_t n = report.left_view_rms_px.size();
  double max_rms = 0.1;
  for (size_t v = 0; v < n; ++v) {
    for (double r : {report.left_view_rms_px[v], report.right_view_rms_px[v]}) {
      if (std::isfinite(r)) max_rms = std::max(max_rms, r);
    }
  }
  const double width = 80 + 40.0 * n, height = 320, plot_h = 240, x0 = 60, y0 = 270;
  std::ostringstream svg;
  svg << fmt::format(
             R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="11">)",
             width, height)
      << "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << fmt::format(
             R"(<text x="{}" y="16" font-size="13">reprojection RMS per view (px): left blue, right orange</text>)",
             x0)
      << "\n";
  svg << fmt::format(R"(<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="black"/>)", x0, y0,
                     width - 10, y0)
      << "\n";
  svg << fmt::format(R"(<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="black"/>)", x0, y0, x0,
                     y0 - plot_h)
      << "\n";
  for (int t = 0; t <= 4; ++t) {
    const double value = max_rms * t / 4, y = y0 - plot_h * t / 4;
    svg << fmt::format(R"(<text x="{}" y="{}" text-anchor="end">{:.3f}</text>)", x0 - 4, y + 4,
                       value)
        << "\n";
  }
  for (size_t v = 0; v < n; ++v) {
    const double x = x0 + 10 + 40.0 * v;
    const double values[2] = {report.left_view_rms_px[v], report.right_view_rms_px[v]};
    const char* colours[2] = {"#1f77b4", "#ff7f0e"};
    for (int s = 0; s < 2; ++s) {
      if (!std::isfinite(values[s])) continue;
      const double h = plot_h * values[s] / max_rms;
      svg << fmt::format(R"(<rect x="{}" y="{}" width="14" height="{}" fill="{}"/>)", x + 15 * s,
                         y0 - h, h, colours[s])
          << "\n";
    }
    svg << fmt::format(R"(<text x="{}" y="{}" text-anchor="middle">{}</text>)", x + 15, y0 + 14, v)
        << "\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace linesight::calib
