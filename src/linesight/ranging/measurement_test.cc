#include "linesight/ranging/measurement.h"

#include <cmath>

#include <gtest/gtest.h>

namespace linesight {
namespace {

using Role = Measurement::Role;

TEST(FuseNearestSurface, WithoutMeasurementsTheMatchedReadingStays) {
  const FusedSurface f = FuseNearestSurface(20.0, 0.1, {}, 1.0);
  EXPECT_FALSE(f.adopted);
  EXPECT_EQ(f.disparity_px, 20.0);
  EXPECT_EQ(f.sigma_px, 0.1);
  EXPECT_TRUE(std::isnan(f.disagreement_px));
  EXPECT_TRUE(f.kind.empty());
}

TEST(FuseNearestSurface, AnEstimateReplacesTheMatchedReadingAndItsDisagreementJoinsSigma) {
  const FusedSurface f =
      FuseNearestSurface(20.0, 0.1, {{Role::kEstimate, "surface", 20.4, 0.05, 0.3}}, 2.0);
  EXPECT_TRUE(f.adopted);
  EXPECT_EQ(f.kind, "surface");
  EXPECT_EQ(f.disparity_px, 20.4);
  EXPECT_NEAR(f.sigma_px, std::sqrt(0.1 * 0.1 + 0.05 * 0.05 + 0.6 * 0.6), 1e-15);
  EXPECT_EQ(f.disagreement_px, 0.3);
}

TEST(FuseNearestSurface, ALowerBoundCountsOnlyInFrontOfTheMatchedReading) {
  // Behind the matched reading it says nothing the matched value does not: the next decides.
  const FusedSurface behind = FuseNearestSurface(
      20.0, 0.1,
      {{Role::kLowerBound, "edges", 19.8, 0.05, -0.2}, {Role::kCheck, "surface", 20.1, 0.0, 0.1}},
      1.0);
  EXPECT_FALSE(behind.adopted);
  EXPECT_EQ(behind.disparity_px, 20.0);
  EXPECT_NEAR(behind.sigma_px, std::hypot(0.1, 0.1), 1e-15);
  EXPECT_EQ(behind.disagreement_px, 0.1);
  const FusedSurface in_front =
      FuseNearestSurface(20.0, 0.1, {{Role::kLowerBound, "edges", 20.3, 0.05, 0.3}}, 1.0);
  EXPECT_TRUE(in_front.adopted);
  EXPECT_EQ(in_front.kind, "edges");
  EXPECT_EQ(in_front.disparity_px, 20.3);
  EXPECT_NEAR(in_front.sigma_px, std::sqrt(0.01 + 0.0025 + 0.09), 1e-15);
}

TEST(FuseNearestSurface, TheFirstMeasurementThatQualifiesDecides) {
  const FusedSurface f = FuseNearestSurface(
      20.0, 0.1,
      {{Role::kCheck, "surface", 21.0, 0.0, 1.0}, {Role::kEstimate, "surface", 20.5, 0.0, 0.5}},
      1.0);
  EXPECT_FALSE(f.adopted);  // a check ahead of the estimate keeps the matched reading
  EXPECT_EQ(f.disparity_px, 20.0);
  EXPECT_NEAR(f.sigma_px, std::hypot(0.1, 1.0), 1e-15);
  // Weight 0: the disagreement does not enter sigma.
  EXPECT_EQ(
      FuseNearestSurface(20.0, 0.1, {{Role::kCheck, "surface", 21.0, 0.0, 1.0}}, 0.0).sigma_px,
      0.1);
}

}  // namespace
}  // namespace linesight
