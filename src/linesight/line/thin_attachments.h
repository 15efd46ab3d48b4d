// Thin structures leaving the conductor at its own depth: a string or wire hanging from the line,
// a plastic sheet seen edge-on, a strand standing off it. They are a few millimetres across, 1-4
// px beyond a metre, thinner than any body the obstacle finder keeps and too thin for the dense
// matcher, whose windows give such a pixel the background's disparity.
//
// Method: a sweep at the line's depth. A pixel of the left view that shows an object at disparity
// d sees the same grey level in the right view d px to the left; a pixel that shows the background
// sees it at the background's disparity instead. So a pixel is taken as part of a thin structure
// at d when
//   - its grey level differs from the right view's at the background's disparity (the matcher's
//     there, or its row neighbours' when the matcher gave the pixel the line's depth) by at least
//     min_contrast: what it shows is not the background, and
//   - it agrees with the right view at d within max_match_ratio of that difference.
// Starting from the ring of pixels just outside the conductor's image band, at disparities about
// the line's there (the model's disparity on a thin receding tube reads several per cent low), the
// structure is followed outward pixel by pixel (8-neighbours), each pixel at the disparity within
// max_disparity_step_px of its neighbour's that agrees best: a structure leaving the line is
// continuous in depth. A structure is kept when it reaches min_length_m beyond the conductor's
// surface, measured in 3D from the axis. The background rarely passes both tests, and a chance
// pass seldom starts at the line and continues over many pixels.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"
#include "linesight/line/conductor.h"

namespace linesight {

struct ThinAttachmentOptions {
  double reach_m = 0.7;       // followed up to this far from the conductor's axis (m)
  double max_reach_px = 480;  // and this far in the image (px)
  // The conductor's band: its image half-width plus this margin (px) about the model's curve.
  double band_margin_px = 2.0;
  double min_contrast = 10.0;    // grey levels between the structure and the background it hides
  double max_match_ratio = 0.5;  // its mismatch at its disparity, relative to that contrast
  // Disparities tried at the ring beside the line's point at depth Z: from d(Z) (1 - range) to
  // d(Z - seed_reach_m) (1 + range) (a structure hanging from a nearer point of the line may run
  // beside the band before it leaves it).
  double seed_disparity_range = 0.15;
  double seed_reach_m = 0.2;
  double max_disparity_step_px = 0.5;  // between neighbouring pixels of one structure
  // Shortest reach beyond the conductor's surface (m), and from the line's point where it was
  // found (px): shorter chains of passing pixels arise by chance in the background's texture.
  double min_length_m = 0.03;
  double min_reach_px = 18;
  int min_pixels = 6;
  void Check() const;
};

struct ThinAttachment {
  cv::Rect box;  // rectified left image
  cv::Mat mask;  // CV_8UC1 over box
  int pixels = 0;
  double root_tau = 0;  // where it leaves the line (image arc coordinate, px)
  double arc_m = 0;     // arc of that point along the line (m)
  // Its stretch of the line: the arcs where its pixels touch the conductor's band (a sheet hangs
  // from a stretch, a string from a point), at their own depths (m).
  double arc_begin_m = 0, arc_end_m = 0;
  double distance_m = 0;    // its depth (m)
  double disparity_px = 0;  // the structure's median disparity
  // Sizes in the image, in metres at distance_m (a hanging structure lies in the plane across
  // the line, which faces the camera): its reach beyond the conductor's surface from the line's
  // point where it was found (95th percentile over its pixels), the offset of its farthest point
  // from there along the image's rows (side, + to the right) and columns (down, + downward), and
  // its mean width (area over length).
  double length_m = 0;
  double down_m = 0, side_m = 0;
  double width_m = 0;
};

// `left`, `right`: rectified images (CV_32FC1 grey or CV_32FC3 colour; grey levels summed over
// the channels); `disparity` the dense map (CV_32FC1, +inf
// invalid); the line between image arcs tau_from and tau_to is looked at. Ordered by root_tau.
std::vector<ThinAttachment> FindThinAttachments(const cv::Mat& left, const cv::Mat& right,
                                                const cv::Mat& disparity,
                                                const ConductorCurve& curve,
                                                const StereoGeometry& g, double radius_m,
                                                double tau_from, double tau_to,
                                                const ThinAttachmentOptions& o);

}  // namespace linesight
