// Superpixel segmentation of the left image for ISGM's plane refinement: a grid-seeded SLIC variant
// (Achanta et al., PAMI 2012) tuned for speed.
//
// Why our own and not OpenCV ximgproc: at 752x480 OpenCV's SLIC costs 35-45 ms for 3 iterations and
// SEEDS about 20 ms, LSC over 100 ms, while the whole ISGM budget (OpenCV SGBM_3WAY on 2 cores) is
// about 30 ms. This variant compares each pixel only with the 4 cluster centres of its own grid
// cell and the 3 cells of the quadrant it lies in, works on 8-bit Lab (or grey) with integer centre
// sums, starts from the grid cells' mean colours and runs 2 rounds; it costs a few ms. It is
// deterministic and independent of the thread count: pixel assignment is a pure function of the
// previous centres and centre updates are exact integer sums.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

struct SuperpixelOptions {
  // px: grid spacing of the seeds (about the superpixel side length), >= 4.
  int region_size = 12;
  // Weight of the spatial distance (SLIC's m): the intensity difference (8-bit grey, or Lab units
  // for colour input) that counts as much as a displacement of one region_size, > 0.
  double compactness = 14.0;
  // Rounds of centre update + reassignment, starting from the grid cells, >= 1.
  int iterations = 2;
  // Connected pieces smaller than this fraction of region_size^2 join a neighbour, in [0, 1].
  double min_size_ratio = 0.25;

  void Check() const;
};

// Labels (CV_32SC1, values 0..num_segments-1, every segment 4-connected) for an 8-bit grey or BGR
// image. Labels are numbered in raster order of each segment's first pixel.
cv::Mat SegmentSuperpixels(const cv::Mat& image, const SuperpixelOptions& options,
                           int* num_segments);

namespace detail {

// One SLIC assignment of every pixel of `features` (CV_8UC1 or CV_8UC3) to the nearest of the
// centres of its grid cell and the three neighbouring cells of its quadrant. centres: per cluster
// (x, y, f0[, f1, f2]) as floats; grid nx x ny.
void AssignPixelsToCentres(const cv::Mat& features, const std::vector<float>& centres, int grid_x,
                           int grid_y, double spatial_weight, cv::Mat* labels);

// Relabels `labels` so that every label is one 4-connected piece of at least min_size pixels
// (smaller pieces join the neighbouring segment met first in raster order). Returns the number of
// segments.
int EnforceConnectivity(cv::Mat* labels, int min_size);

// The grey-feature kernel of AssignPixelsToCentres (SIMD, superpixel_kernels.cc): labels of rows
// [ya, yb) x columns [xa, xb) from four candidate centres (ids increasing; ties go to the smaller
// id), with distance spatial_weight * (dx² + dy²) + (f - cf)².
void AssignGreyBlock(const uint8_t* features, size_t feature_stride, int width, int ya, int yb,
                     int xa, int xb, const int32_t* ids, const float* cx, const float* cy,
                     const float* cf, float spatial_weight, int32_t* labels, size_t label_stride);

}  // namespace detail
}  // namespace linesight
