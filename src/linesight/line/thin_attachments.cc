#include "linesight/line/thin_attachments.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <vector>

#include "linesight/core/disparity.h"
#include "linesight/core/error.h"
#include "linesight/line/line_quantile.h"

namespace linesight {
namespace {

// How far along its row a pixel looks for the background's disparity when the matcher gave the
// pixel itself the structure's (px each way).
constexpr int kRowSearchPx = 48;
constexpr double kDisparityStepPx = 0.25;  // between the disparities tried
constexpr double kLocalisationPx = 2.0;
constexpr double kTiePx = 2.0;  // grey levels (summed over the channels) within which costs tie
// A pixel whose dense disparity exceeds the structure's by this factor lies on a nearer surface.
constexpr double kNearerSurface = 1.15;

// Sum over the channels of |left(x, y) - right(xr, y)| (right linearly interpolated along the
// row; CV_32FC1 or CV_32FC3 images); +inf when xr is outside the image.
double Distance(const cv::Mat& left, const cv::Mat& right, int x, int y, double xr) {
  if (xr < 0 || xr > right.cols - 1.001) return std::numeric_limits<double>::infinity();
  const int x0 = static_cast<int>(xr);
  const double fx = xr - x0;
  const int channels = left.channels();
  const float* l = left.ptr<float>(y) + x * channels;
  const float* r = right.ptr<float>(y) + x0 * channels;
  double sum = 0;
  for (int c = 0; c < channels; ++c) {
    sum += std::fabs(l[c] - ((1 - fx) * r[c] + fx * r[c + channels]));
  }
  return sum;
}

struct Pixel {
  int x, y;
  double d;
  int seed;  // index of the ring pixel it was reached from
};

class Sweep {
 public:
  Sweep(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
        const StereoGeometry& g, const ThinAttachmentOptions& o)
      : left_(left), right_(right), disparity_(disparity), g_(g), o_(o) {}

  // The disparity among `from`..`to` (kDisparityStepPx apart) at which pixel (x, y) agrees best
  // with the right view, if the pixel passes both tests there (see the header).
  bool Test(int x, int y, double from, double to, double* d) const {
    costs_.clear();
    size_t best_index = 0;
    for (double c = from; c <= to + 1e-9; c += kDisparityStepPx) {
      costs_.push_back(Distance(left_, right_, x, y, x - c));
      if (costs_.back() < costs_[best_index]) best_index = costs_.size() - 1;
    }
    if (costs_.empty() || !std::isfinite(costs_[best_index])) return false;
    const double best = costs_[best_index];
    // A structure of even grey matches equally well across its width: the middle of the run of
    // disparities about the best that match as well (within kTiePx).
    size_t lo = best_index, hi = best_index;
    while (lo > 0 && costs_[lo - 1] <= best + kTiePx) --lo;
    while (hi + 1 < costs_.size() && costs_[hi + 1] <= best + kTiePx) ++hi;
    const double best_d = from + 0.5 * static_cast<double>(lo + hi) * kDisparityStepPx;
    // A pixel the matcher places on a surface well in front of the structure shows that surface.
    const float matched = disparity_.at<float>(y, x);
    if (IsValidDisparity(matched) &&
        matched + g_.disparity_offset_px > kNearerSurface * (best_d + g_.disparity_offset_px)) {
      return false;
    }
    const double contrast = Contrast(x, y, best_d);
    if (!std::isfinite(contrast) || contrast < o_.min_contrast ||
        best > o_.max_match_ratio * contrast) {
      return false;
    }
    // The match must be placed along the row: kLocalisationPx to one side or the other the right
    // view differs (a stripe along the rows matches at any disparity).
    const double d_lo = from + static_cast<double>(lo) * kDisparityStepPx;
    const double d_hi = from + static_cast<double>(hi) * kDisparityStepPx;
    const double side = std::max(Distance(left_, right_, x, y, x - d_lo + kLocalisationPx),
                                 Distance(left_, right_, x, y, x - d_hi - kLocalisationPx));
    if (!(side >= o_.min_contrast && best <= o_.max_match_ratio * side)) return false;
    *d = best_d;
    return true;
  }

  // How far pixel (x, y) is from the background the right view shows behind a structure at
  // disparity d (the least over +-1 px about the background's disparity); 0 without one.
  double Contrast(int x, int y, double d) const {
    double background_d = 0;
    if (!Background(x, y, d, &background_d)) return 0;
    double contrast = std::numeric_limits<double>::infinity();
    for (int delta = -1; delta <= 1; ++delta) {
      contrast =
          std::min(contrast, Distance(left_, right_, x, y, std::round(x - background_d) + delta));
    }
    return contrast;
  }

  // The background's disparity behind pixel (x, y) for a structure at disparity d: the matcher's
  // there when it is well beyond the structure (under 0.8 of its disparity), else the mean of the
  // nearest such on the row on either side.
  bool Background(int x, int y, double d, double* background_d) const {
    const float* row = disparity_.ptr<float>(y);
    const double limit = 0.8 * (d + g_.disparity_offset_px) - g_.disparity_offset_px;
    auto far = [&](float v) { return IsValidDisparity(v) && v < limit; };
    if (far(row[x])) {
      *background_d = row[x];
      return true;
    }
    double sum = 0;
    int count = 0;
    for (int side : {-1, 1}) {
      for (int k = 1; k <= kRowSearchPx; ++k) {
        const int xx = x + side * k;
        if (xx < 0 || xx >= disparity_.cols) break;
        if (far(row[xx])) {
          sum += row[xx];
          ++count;
          break;
        }
      }
    }
    if (count == 0) return false;
    *background_d = sum / count;
    return true;
  }

  mutable std::vector<double> costs_;  // scratch
  const cv::Mat& left_;
  const cv::Mat& right_;
  const cv::Mat& disparity_;
  const StereoGeometry& g_;
  const ThinAttachmentOptions& o_;
};

}  // namespace

void ThinAttachmentOptions::Check() const {
  CheckOption(reach_m > 0 && reach_m <= 3, "ThinAttachmentOptions.reach_m", reach_m,
              "must be in (0, 3] m");
  CheckOption(max_reach_px > 0, "ThinAttachmentOptions.max_reach_px", max_reach_px, "must be > 0");
  CheckOption(band_margin_px >= 0 && band_margin_px <= 20, "ThinAttachmentOptions.band_margin_px",
              band_margin_px, "must be in [0, 20] px");
  CheckOption(min_contrast > 0, "ThinAttachmentOptions.min_contrast", min_contrast,
              "must be > 0 grey levels");
  CheckOption(max_match_ratio > 0 && max_match_ratio < 1, "ThinAttachmentOptions.max_match_ratio",
              max_match_ratio, "must be in (0, 1)");
  CheckOption(seed_reach_m >= 0 && seed_reach_m <= 2, "ThinAttachmentOptions.seed_reach_m",
              seed_reach_m, "must be in [0, 2] m");
  CheckOption(seed_disparity_range >= 0 && seed_disparity_range < 0.5,
              "ThinAttachmentOptions.seed_disparity_range", seed_disparity_range,
              "must be in [0, 0.5)");
  CheckOption(max_disparity_step_px >= 0 && max_disparity_step_px <= 4,
              "ThinAttachmentOptions.max_disparity_step_px", max_disparity_step_px,
              "must be in [0, 4] px");
  CheckOption(min_length_m > 0, "ThinAttachmentOptions.min_length_m", min_length_m, "must be > 0");
  CheckOption(min_reach_px >= 0, "ThinAttachmentOptions.min_reach_px", min_reach_px,
              "must be >= 0 px");
  CheckOption(min_pixels >= 1, "ThinAttachmentOptions.min_pixels", min_pixels, "must be >= 1");
}

std::vector<ThinAttachment> FindThinAttachments(const cv::Mat& left, const cv::Mat& right,
                                                const cv::Mat& disparity,
                                                const ConductorCurve& curve,
                                                const StereoGeometry& g, double radius_m,
                                                double tau_from, double tau_to,
                                                const ThinAttachmentOptions& o) {
  o.Check();
  std::vector<ThinAttachment> out;
  if (left.empty() || (left.type() != CV_32FC1 && left.type() != CV_32FC3) ||
      right.size() != left.size() || right.type() != left.type() ||
      disparity.size() != left.size() || disparity.type() != CV_32FC1 || curve.points.size() < 2) {
    return out;
  }
  const cv::Rect image(0, 0, left.cols, left.rows);
  const double offset = g.disparity_offset_px;
  auto depth_of = [&](double d) { return g.DepthFromDisparity(d); };
  // The conductor's band: within its image half-width plus the margin of the model's curve.
  auto in_band = [&](int x, int y) {
    double tau = 0, lateral = 0;
    curve.ImageCoordinates(x, y, &tau, &lateral);
    const double d = curve.DisparityAt(tau);
    if (!(d + offset > 0)) return false;
    return std::fabs(lateral) <= radius_m * (d + offset) / g.baseline_m + o.band_margin_px;
  };
  const Sweep sweep(left, right, disparity, g, o);

  // 0: on no structure; k > 0: on structure k.
  cv::Mat label = cv::Mat::zeros(left.size(), CV_32SC1);
  cv::Mat found_d(left.size(), CV_32FC1, cv::Scalar(0));  // disparity of a structure's pixel
  cv::Mat tried = cv::Mat::zeros(left.size(), CV_8UC1);   // ring pixels tried as seeds
  std::vector<std::vector<Pixel>> structures;
  struct Seed {
    double tau, reach_px, d;
  };
  std::vector<Seed> seeds;
  std::deque<Pixel> queue;
  const double nearest = std::max(curve.DisparityAt(tau_from), curve.DisparityAt(tau_to));
  for (double tau = tau_from; tau <= tau_to; tau += 0.5) {
    const double d_line = curve.DisparityAt(tau);
    if (!(d_line + offset > 0.5)) continue;
    const double z = depth_of(d_line);
    const double band = radius_m * g.focal_px / z + o.band_margin_px;
    const double reach_px = std::min(o.max_reach_px, o.reach_m * g.focal_px / z);
    const cv::Point2d c = curve.ImagePoint(tau);
    for (int side : {-1, 1}) {
      for (int k = 1; k <= 2; ++k) {
        const cv::Point2d q = c + side * (band + k) * curve.normal;
        const cv::Point p(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)));
        // Neighbouring points of the line round to the same ring pixel: it is tried once.
        if (!image.contains(p) || label.at<int>(p) != 0 || tried.at<std::uint8_t>(p) != 0 ||
            in_band(p.x, p.y)) {
          continue;
        }
        tried.at<std::uint8_t>(p) = 1;
        // Up to the disparity seed_reach_m nearer: a structure hanging from a nearer point of the
        // line may run beside the band before it leaves it (a string swung sideways, which the
        // view foreshortens along the line's image).
        const double z_nearer = std::max(z - o.seed_reach_m, 0.5 * z);
        const double d_nearer = g.focal_px * g.baseline_m / z_nearer - offset;
        const double lo = (d_line + offset) * (1 - o.seed_disparity_range) - offset;
        const double hi = (d_nearer + offset) * (1 + o.seed_disparity_range) - offset;
        // Farther still: at the matcher's disparity, when that lies between this point's and the
        // nearest point's of the line.
        const float matched = disparity.at<float>(p);
        const bool beside =
            IsValidDisparity(matched) && matched > hi &&
            matched + offset <= (std::max(nearest, d_line) + offset) * (1 + o.seed_disparity_range);
        double d = 0;
        if (!sweep.Test(p.x, p.y, std::max(lo, 0.5 - offset), hi, &d) &&
            !(beside && sweep.Test(p.x, p.y, matched - 1.0, matched + 1.0, &d))) {
          continue;
        }
        seeds.push_back({tau, reach_px, d});
        structures.emplace_back();
        const int id = static_cast<int>(structures.size());
        label.at<int>(p) = id;
        found_d.at<float>(p) = static_cast<float>(d);
        queue.push_back({p.x, p.y, d, static_cast<int>(seeds.size()) - 1});
        // Follow the structure outward from this pixel.
        while (!queue.empty()) {
          const Pixel px = queue.front();
          queue.pop_front();
          structures.back().push_back(px);
          for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
              const cv::Point n(px.x + dx, px.y + dy);
              if (!image.contains(n) || label.at<int>(n) != 0) continue;
              if (in_band(n.x, n.y)) continue;
              double tau_n = 0, lateral_n = 0;
              curve.ImageCoordinates(n.x, n.y, &tau_n, &lateral_n);
              if (std::fabs(lateral_n) > seeds[px.seed].reach_px) continue;
              // About the mean disparity of its neighbours already on the structure: a single
              // pixel's best disparity is noisy, and a chain of them would drift.
              double sum = 0;
              int count = 0;
              for (int ey = -1; ey <= 1; ++ey) {
                for (int ex = -1; ex <= 1; ++ex) {
                  const cv::Point e(n.x + ex, n.y + ey);
                  if (image.contains(e) && label.at<int>(e) == id) {
                    sum += found_d.at<float>(e);
                    ++count;
                  }
                }
              }
              const double centre = sum / count;
              double dn = 0;
              // A pixel that fails here stays open: from another neighbour, or as a seed, it is
              // tried at other disparities.
              if (!sweep.Test(n.x, n.y, centre - o.max_disparity_step_px,
                              centre + o.max_disparity_step_px, &dn)) {
                continue;
              }
              label.at<int>(n) = id;
              found_d.at<float>(n) = static_cast<float>(dn);
              queue.push_back({n.x, n.y, dn, px.seed});
            }
          }
        }
      }
    }
  }

  const CurveLocator locator(curve);
  for (const std::vector<Pixel>& s : structures) {
    if (static_cast<int>(s.size()) < o.min_pixels) continue;
    // Its size in the image, in metres at the depth where it leaves the line (its seed's): a
    // hanging structure lies in the plane across the line there, which faces the camera. Neither
    // the pixels' own disparities nor the model's 3D axis (a few cm off in depth, see
    // conductor_faults.h) are good to a centimetre.
    const Seed& root = seeds[static_cast<size_t>(s[0].seed)];
    const double root_z = depth_of(root.d);
    const double pixel_m = root_z / g.focal_px;
    const double radius_px = radius_m / pixel_m;
    const cv::Point2d at = curve.ImagePoint(root.tau);
    std::vector<double> lateral, from_root, disparities;
    int x0 = s[0].x, x1 = s[0].x, y0 = s[0].y, y1 = s[0].y;
    // Its stretch of the line: where its pixels touch the band (within 2 px of the ring).
    double touch_from = std::numeric_limits<double>::infinity(), touch_to = -touch_from;
    for (const Pixel& p : s) {
      double tau = 0, nu = 0;
      curve.ImageCoordinates(p.x, p.y, &tau, &nu);
      lateral.push_back(std::fabs(nu));
      const double d_line = curve.DisparityAt(tau);
      if (d_line + offset > 0 &&
          std::fabs(nu) <= radius_m * (d_line + offset) / g.baseline_m + o.band_margin_px + 3) {
        const cv::Point2d c = curve.ImagePoint(tau);
        const double z = depth_of(p.d);
        const double arc =
            locator.Locate({(c.x - g.cx) * z / g.focal_px, (c.y - g.cy) * z / g.focal_px, z}).arc_m;
        touch_from = std::min(touch_from, arc);
        touch_to = std::max(touch_to, arc);
      }
      from_root.push_back(std::hypot(p.x - at.x, p.y - at.y));
      disparities.push_back(p.d);
      x0 = std::min(x0, p.x);
      x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y);
      y1 = std::max(y1, p.y);
    }
    // How far it gets from the line's point where it was found, and how far it leaves the band.
    const double reach_px = line_detail::Quantile(from_root, 0.95);
    const double length = (reach_px - radius_px) * pixel_m;
    const double leaves = (line_detail::Quantile(lateral, 0.95) - radius_px) * pixel_m;
    if (length < o.min_length_m || reach_px < o.min_reach_px || leaves < 0.5 * o.min_length_m) {
      continue;
    }
    size_t far = 0;
    for (size_t i = 0; i < from_root.size(); ++i) {
      if (std::fabs(from_root[i] - reach_px) < std::fabs(from_root[far] - reach_px)) far = i;
    }
    const double area = static_cast<double>(s.size()) * pixel_m * pixel_m;
    ThinAttachment a;
    a.pixels = static_cast<int>(s.size());
    a.box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
    a.mask = cv::Mat::zeros(a.box.size(), CV_8UC1);
    for (const Pixel& p : s) a.mask.at<std::uint8_t>(p.y - y0, p.x - x0) = 255;
    a.disparity_px = line_detail::Quantile(disparities, 0.5);
    a.root_tau = root.tau;
    a.distance_m = root_z;
    a.arc_m = locator.Locate({(at.x - g.cx) * pixel_m, (at.y - g.cy) * pixel_m, root_z}).arc_m;
    a.arc_begin_m = std::min(a.arc_m, touch_from);
    a.arc_end_m = std::max(a.arc_m, touch_to);
    a.length_m = length;
    a.down_m = (s[far].y - at.y) * pixel_m;
    a.side_m = (s[far].x - at.x) * pixel_m;
    a.width_m = area / std::max(length, 0.01);
    out.push_back(std::move(a));
  }
  std::sort(out.begin(), out.end(), [](const ThinAttachment& a, const ThinAttachment& b) {
    return a.root_tau < b.root_tau;
  });
  return out;
}

}  // namespace linesight
