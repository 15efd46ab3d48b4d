#include "linesight/stereo/superpixels.h"

#include <gtest/gtest.h>
#include <hwy/tests/hwy_gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <queue>
#include <set>

#include "linesight/core/error.h"

namespace linesight {
namespace {

cv::Mat RandomColourImage(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(height, width, CV_8UC3);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(7, 7), 2.0);
  return image;
}

// Number of 4-connected pieces of every label (a naive flood fill).
std::map<int, int> PiecesPerLabel(const cv::Mat& labels) {
  cv::Mat seen(labels.size(), CV_8UC1, cv::Scalar(0));
  std::map<int, int> pieces;
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      if (seen.at<uint8_t>(y, x)) continue;
      const int label = labels.at<int32_t>(y, x);
      ++pieces[label];
      std::queue<cv::Point> queue;
      queue.push({x, y});
      seen.at<uint8_t>(y, x) = 1;
      while (!queue.empty()) {
        const cv::Point p = queue.front();
        queue.pop();
        const cv::Point next[4] = {{p.x - 1, p.y}, {p.x + 1, p.y}, {p.x, p.y - 1}, {p.x, p.y + 1}};
        for (const cv::Point& q : next) {
          if (q.x < 0 || q.y < 0 || q.x >= labels.cols || q.y >= labels.rows) continue;
          if (seen.at<uint8_t>(q) || labels.at<int32_t>(q) != label) continue;
          seen.at<uint8_t>(q) = 1;
          queue.push(q);
        }
      }
    }
  }
  return pieces;
}

TEST(SuperpixelOptions, DefaultsAreValid) { EXPECT_NO_THROW(SuperpixelOptions().Check()); }

TEST(SuperpixelOptions, Boundaries) {
  SuperpixelOptions o;
  o.region_size = 4;
  EXPECT_NO_THROW(o.Check());
  o.region_size = 3;
  EXPECT_THROW(o.Check(), OptionError);
  o = SuperpixelOptions();
  o.compactness = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = SuperpixelOptions();
  o.iterations = 0;
  EXPECT_THROW(o.Check(), OptionError);
  o = SuperpixelOptions();
  o.min_size_ratio = 1.0;
  EXPECT_NO_THROW(o.Check());
  o.min_size_ratio = 1.01;
  EXPECT_THROW(o.Check(), OptionError);
}

TEST(SegmentSuperpixels, LabelsAreDenseConnectedAndNumberedInRasterOrder) {
  const cv::Mat image = RandomColourImage(311, 239, 3);
  SuperpixelOptions o;
  int n = 0;
  const cv::Mat labels = SegmentSuperpixels(image, o, &n);
  ASSERT_EQ(labels.type(), CV_32SC1);
  ASSERT_EQ(labels.size(), image.size());
  // About one segment per grid cell (26 x 20 seeds).
  EXPECT_GT(n, 26 * 20 / 2);
  EXPECT_LT(n, 26 * 20 * 2);
  const auto pieces = PiecesPerLabel(labels);
  ASSERT_EQ(static_cast<int>(pieces.size()), n);
  for (const auto& [label, count] : pieces) {
    EXPECT_EQ(count, 1) << "label " << label << " is not connected";
  }
  // Raster order of first pixels: labels appear as 0, 1, 2, ... when scanning.
  int next = 0;
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      const int l = labels.at<int32_t>(y, x);
      ASSERT_LE(l, next);
      if (l == next) ++next;
    }
  }
  EXPECT_EQ(next, n);
}

TEST(SegmentSuperpixels, FollowsAStrongColourEdgeOffTheGrid) {
  // Two flat colours split at x = 53, which is not a grid line of region_size 12.
  cv::Mat image(96, 120, CV_8UC3, cv::Scalar(40, 60, 200));
  image.colRange(53, 120).setTo(cv::Scalar(200, 180, 30));
  int n = 0;
  const cv::Mat labels = SegmentSuperpixels(image, SuperpixelOptions(), &n);
  std::set<int> left, right;
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) (x < 53 ? left : right).insert(labels.at<int32_t>(y, x));
  }
  for (int l : left) EXPECT_EQ(right.count(l), 0u) << "segment " << l << " crosses the edge";
}

TEST(SegmentSuperpixels, GreyInputAndTinyImage) {
  cv::Mat grey(7, 5, CV_8UC1, cv::Scalar(9));
  int n = 0;
  const cv::Mat labels = SegmentSuperpixels(grey, SuperpixelOptions(), &n);
  EXPECT_EQ(n, 1);
  EXPECT_EQ(cv::countNonZero(labels), 0);
}

TEST(SegmentSuperpixels, RejectsFloatImage) {
  int n = 0;
  EXPECT_THROW(SegmentSuperpixels(cv::Mat(10, 10, CV_32FC1), SuperpixelOptions(), &n), InputError);
}

TEST(SegmentSuperpixels, IndependentOfThreadCount) {
  const cv::Mat image = RandomColourImage(257, 131, 11);
  const int saved = cv::getNumThreads();
  int n1 = 0, n2 = 0;
  cv::setNumThreads(1);
  const cv::Mat one = SegmentSuperpixels(image, SuperpixelOptions(), &n1);
  cv::setNumThreads(4);
  const cv::Mat four = SegmentSuperpixels(image, SuperpixelOptions(), &n2);
  cv::setNumThreads(saved);
  EXPECT_EQ(n1, n2);
  EXPECT_EQ(cv::countNonZero(one != four), 0);
}

// Naive reference of AssignPixelsToCentres for grey features: every pixel against the centres of
// its cell and of the three cells of its quadrant, nearest wins, ties to the smaller index.
cv::Mat NaiveAssignGrey(const cv::Mat& features, const std::vector<float>& centres, int grid_x,
                        int grid_y, double spatial_weight) {
  const int width = features.cols, height = features.rows;
  const auto start = [](int cell, int size, int cells) {
    return static_cast<int>((static_cast<int64_t>(cell) * size + cells - 1) / cells);
  };
  const auto cell_of = [&](int v, int size, int cells) {
    int c = 0;
    while (start(c + 1, size, cells) <= v) ++c;
    return c;
  };
  const float weight = static_cast<float>(spatial_weight);
  cv::Mat labels(features.size(), CV_32SC1);
  for (int y = 0; y < height; ++y) {
    const int gy = cell_of(y, height, grid_y);
    const int y_mid = (start(gy, height, grid_y) + start(gy + 1, height, grid_y)) / 2;
    const int gy_other = y < y_mid ? gy - 1 : gy + 1;
    for (int x = 0; x < width; ++x) {
      const int gx = cell_of(x, width, grid_x);
      const int x_mid = (start(gx, width, grid_x) + start(gx + 1, width, grid_x)) / 2;
      const int gx_other = x < x_mid ? gx - 1 : gx + 1;
      std::vector<int> candidates = {gy * grid_x + gx};
      const bool col = gx_other >= 0 && gx_other < grid_x;
      const bool row = gy_other >= 0 && gy_other < grid_y;
      if (col) candidates.push_back(gy * grid_x + gx_other);
      if (row) candidates.push_back(gy_other * grid_x + gx);
      if (row && col) candidates.push_back(gy_other * grid_x + gx_other);
      int best = -1;
      float best_distance = 0;
      for (int c : candidates) {
        const float* centre = &centres[static_cast<size_t>(c) * 3];
        const float dy = static_cast<float>(y) - centre[1];
        const float dx = static_cast<float>(x) - centre[0];
        const float dc = static_cast<float>(features.at<uint8_t>(y, x)) - centre[2];
        float distance = weight * dy * dy;
        distance = distance + weight * dx * dx;
        distance += dc * dc;
        if (best < 0 || distance < best_distance || (distance == best_distance && c < best)) {
          best = c;
          best_distance = distance;
        }
      }
      labels.at<int32_t>(y, x) = best;
    }
  }
  return labels;
}

class SuperpixelKernelTest : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(SuperpixelKernelTest);

TEST_P(SuperpixelKernelTest, GreyAssignmentEqualsNaiveReference) {
  cv::RNG rng(5);
  // Odd sizes, cells narrower than a vector, a single cell, a single row.
  const std::vector<std::array<int, 4>> cases = {
      {311, 239, 24, 18}, {37, 9, 3, 1}, {5, 5, 1, 1}, {70, 1, 7, 1}, {129, 65, 5, 3}};
  for (const auto& [width, height, grid_x, grid_y] : cases) {
    cv::Mat features(height, width, CV_8UC1);
    rng.fill(features, cv::RNG::UNIFORM, 0, 256);
    // Centres near their cells, and some exactly on a pixel value / position (ties).
    std::vector<float> centres(static_cast<size_t>(grid_x) * grid_y * 3);
    for (int gy = 0; gy < grid_y; ++gy) {
      for (int gx = 0; gx < grid_x; ++gx) {
        float* c = &centres[static_cast<size_t>(gy * grid_x + gx) * 3];
        const float jitter = rng.uniform(0, 4) == 0 ? 0.0f : rng.uniform(-3.0f, 3.0f);
        c[0] = (gx + 0.5f) * width / grid_x + jitter;
        c[1] = (gy + 0.5f) * height / grid_y - jitter;
        c[2] = rng.uniform(0, 3) == 0 ? 128.0f : rng.uniform(0.0f, 255.0f);
      }
    }
    for (const double weight : {0.0, 0.59, 4.0}) {
      cv::Mat labels;
      detail::AssignPixelsToCentres(features, centres, grid_x, grid_y, weight, &labels);
      const cv::Mat expected = NaiveAssignGrey(features, centres, grid_x, grid_y, weight);
      ASSERT_EQ(cv::countNonZero(labels != expected), 0)
          << width << "x" << height << " grid " << grid_x << "x" << grid_y << " weight " << weight;
    }
  }
}

// Naive reference of EnforceConnectivity: flood fill from each unlabelled pixel in raster order.
int NaiveEnforceConnectivity(cv::Mat* labels, int min_size) {
  const int width = labels->cols, height = labels->rows;
  cv::Mat out(labels->size(), CV_32SC1, cv::Scalar(-1));
  int next = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (out.at<int32_t>(y, x) >= 0) continue;
      const int old = labels->at<int32_t>(y, x);
      const int adjacent =
          x > 0 ? out.at<int32_t>(y, x - 1) : (y > 0 ? out.at<int32_t>(y - 1, x) : -1);
      std::vector<cv::Point> piece = {{x, y}};
      out.at<int32_t>(y, x) = next;
      for (size_t i = 0; i < piece.size(); ++i) {
        const cv::Point p = piece[i];
        const cv::Point around[4] = {
            {p.x - 1, p.y}, {p.x + 1, p.y}, {p.x, p.y - 1}, {p.x, p.y + 1}};
        for (const cv::Point& q : around) {
          if (q.x < 0 || q.y < 0 || q.x >= width || q.y >= height) continue;
          if (out.at<int32_t>(q) >= 0 || labels->at<int32_t>(q) != old) continue;
          out.at<int32_t>(q) = next;
          piece.push_back(q);
        }
      }
      if (static_cast<int>(piece.size()) < min_size && adjacent >= 0) {
        for (const cv::Point& p : piece) out.at<int32_t>(p) = adjacent;
      } else {
        ++next;
      }
    }
  }
  out.copyTo(*labels);
  return next;
}

TEST(EnforceConnectivity, EqualsNaiveFloodFillOnAwkwardSizes) {
  cv::RNG rng(13);
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(7, 1), cv::Size(1, 9), cv::Size(37, 23), cv::Size(311, 239)}) {
    for (int min_size : {0, 3, 20}) {
      // Blocky random labels (few values) make pieces of many shapes, including nested ones.
      cv::Mat small((size.height + 2) / 3, (size.width + 2) / 3, CV_32SC1);
      rng.fill(small, cv::RNG::UNIFORM, 0, 4);
      cv::Mat labels;
      cv::resize(small, labels, size, 0, 0, cv::INTER_NEAREST);
      for (int i = 0; i < size.area() / 10; ++i) {
        labels.at<int32_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) =
            rng.uniform(0, 4);
      }
      cv::Mat expected = labels.clone();
      const int n_expected = NaiveEnforceConnectivity(&expected, min_size);
      // The row stripes that are united in parallel follow the thread count (4 per thread): the
      // result must not.
      const int saved_threads = cv::getNumThreads();
      for (int threads : {1, 2, 3, 16}) {
        cv::setNumThreads(threads);
        cv::Mat result = labels.clone();
        const int n = detail::EnforceConnectivity(&result, min_size);
        EXPECT_EQ(n, n_expected) << size << " min_size " << min_size << " threads " << threads;
        EXPECT_EQ(cv::countNonZero(result != expected), 0)
            << size << " min_size " << min_size << " threads " << threads;
      }
      cv::setNumThreads(saved_threads);
    }
  }
}

TEST(EnforceConnectivity, SplitsPiecesAndMergesSmallOnes) {
  // Label 0 in two pieces; label 2 a single pixel (smaller than min_size 2) inside label 1.
  cv::Mat labels = (cv::Mat_<int32_t>(3, 5) << 0, 0, 1, 0, 0,  //
                    1, 1, 1, 1, 1,                             //
                    1, 2, 1, 1, 1);
  const int n = detail::EnforceConnectivity(&labels, 2);
  const cv::Mat expected = (cv::Mat_<int32_t>(3, 5) << 0, 0, 1, 2, 2,  //
                            1, 1, 1, 1, 1,                             //
                            1, 1, 1, 1, 1);
  EXPECT_EQ(n, 3);
  EXPECT_EQ(cv::countNonZero(labels != expected), 0) << labels;
}

}  // namespace
}  // namespace linesight
