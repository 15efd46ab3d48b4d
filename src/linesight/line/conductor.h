// The conductor model: where the line the robot rides on runs, in 3D, from one rectified
// disparity map.
//
// Method. A pinhole pair maps a 3D point to (u, v, d) by a projective transformation, so a straight
// 3D line is a straight line in (u, v, d) space, and the sagging conductor over the few metres a
// robot looks ahead is a gently bent one. Candidate pixels are the thin structures of the working
// range (valid disparities that BodyMask does not call a body: conductors, cables). A RANSAC over
// pairs of candidates finds the line with the most support, where a pixel supports a line when
// its image distance to the line's image is at most the conductor's half-width at its disparity
// (r d / B for radius r, plus the matcher's edge fattening) and its disparity agrees within the
// matching noise. The inliers are then fitted by weighted least squares with a polynomial
// (ConductorOptions::curve_degree; a straight line by default) in the image arc coordinate tau,
// for the lateral offset nu(tau) and the disparity d(tau), re-selecting inliers three times. The 3D
// curve is that (u, v, d) curve back-projected, sampled as a polyline, extended straight from its
// nearest observed part to the point of the line nearest to the camera centre (the robot's
// reference on the line: arc length 0). Further conductors are found in the same way among the
// remaining candidates; a curve whose measured width is below the thinnest conductor's is none.
// The robot's conductor is the one that passes nearest to the camera.
//
// With a previous frame's model the previous curve is tried first as a hypothesis, and the curve
// that continues it (within 3 max_radius_m by median) is the robot's conductor whichever passes
// nearest: the line is tracked over frames, and a curve beside it (another conductor crossing, a
// piece of it that was not joined) neither takes its place nor makes the model ambiguous.
//
// Every result has a status; without an acceptable fit it says why, and nothing downstream guesses.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "linesight/geometry/depth.h"

namespace linesight {

struct ConductorOptions {
  // Working range of the fit (m): candidates are thin structures at these depths.
  double min_depth_m = 0.25;
  double max_depth_m = 12.0;
  // Surfaces at least this wide (m at their depth) are bodies (obstacles), not conductors: above a
  // conductor's diameter (ACSR up to ~40 mm), below a damper weight's (~55 mm).
  double max_conductor_width_m = 0.045;
  // The largest conductor radius the inlier test allows for (m).
  double max_radius_m = 0.025;
  // The thinnest conductor's radius (m): a curve whose radius could be measured (ConductorCurve::
  // radius_m) below it has no width of its own and is no conductor (a line of the matcher's fill
  // beside a near conductor). 3 mm: the smallest stranded overhead conductors are ~6 mm across.
  double min_radius_m = 0.003;
  // Edge fattening of the matcher (px on each side of a thin structure against the sky: about the
  // census window's half-width) and the disparity noise on a conductor (px, plus a relative part).
  double fattening_px = 4.0;
  double disparity_sigma_px = 0.3;
  double disparity_sigma_relative = 0.02;
  int ransac_hypotheses = 200;
  int max_candidates = 4000;        // candidates are subsampled to at most this many
  int min_inliers = 80;             // fewer supporting pixels: no conductor
  double min_image_length_px = 40;  // shorter image extent: seen end-on, no usable line
  int max_conductors = 3;           // conductors looked for in one frame (the robot's + others)
  // Share of a curve's image length (8 px stretches) that must hold supporting pixels: a conductor
  // is seen continuously except where an obstacle hides it; a chance alignment of matching noise
  // on the ground or in the sky is not.
  double min_coverage = 0.5;
  // Degree of the polynomials nu(tau), d(tau) of the refit. 1: a straight 3D line, which is
  // straight in (u, v, d); the sag a span puts into the <= 12 m ahead of the robot is a few cm, and
  // a higher degree lets an obstacle at either end of the seen line (a clamp 0.5 m ahead, a far
  // fitting the line runs into) bend the curve through it. 2 or 3 for a strongly bent line.
  int curve_degree = 1;
  std::uint64_t seed = 1;  // RANSAC sampling (deterministic)
  // The matcher's largest searched disparity (px; 0 = unknown): a pixel at it is censored (the
  // surface is nearer than the search reaches), not a measurement, and is left out.
  double searched_max_disparity_px = 0;

  void Check() const;
};

enum class ConductorStatus {
  kOk,
  kNoDisparity,  // too few valid disparities in the working range
  kNoConductor,  // no line with enough support
  kEndOn,        // the supporting pixels cover too short an image extent (line seen end-on)
  kAmbiguous,    // two conductors pass about equally near the camera (crossing lines)
};
std::string ConductorStatusName(ConductorStatus status);

// One fitted conductor: a curve in (u, v, d) over the image arc coordinate tau, and its 3D
// polyline in the rectified left camera frame.
struct ConductorCurve {
  // Image frame of the fit: tau along `axis` from `centre`, nu along `normal`.
  cv::Point2d centre, axis, normal;
  // Polynomials: nu(tau) = nu0 + nu1 tau + nu2 tau^2 + nu3 tau^3 (px), d(tau) likewise (px), the
  // terms above ConductorOptions::curve_degree 0. A straight 3D line is straight in (u, v, d).
  double nu[4] = {0, 0, 0, 0};
  double d[4] = {0, 0, 0, 0};
  double tau_min = 0, tau_max = 0;  // observed extent (px)
  int inliers = 0;
  double rms_nu_px = 0, rms_d_px = 0;  // residuals of the inliers
  double radius_m = 0;  // estimated conductor radius (0 when it could not be estimated)
  // 3D polyline (m, rectified left frame) with arc lengths: arc 0 is the point of the line nearest
  // to the camera centre; the first point is that point (extrapolated), the rest are observed.
  std::vector<cv::Point3d> points;
  std::vector<double> arcs;
  double closest_approach_m = 0;  // distance of the line from the camera centre

  cv::Point2d ImagePoint(double tau) const;
  // Image arc coordinate of pixel (u, v) and its lateral distance from the curve (px).
  void ImageCoordinates(double u, double v, double* tau, double* lateral_px) const;
  double LateralAt(double tau) const;  // nu(tau)
  double DisparityAt(double tau) const;
};

// Where a 3D point lies relative to a conductor.
struct LinePosition {
  double arc_m = 0;     // arc length of the nearest point of the axis (m)
  double offset_m = 0;  // distance from the axis (m)
  double down_m = 0;    // offset along the local "down" (camera +y orthogonalised to the line)
  double side_m = 0;    // offset along the third axis (tangent x down)
  cv::Vec3d tangent;    // unit tangent of the axis there
};

struct ConductorModel {
  ConductorStatus status = ConductorStatus::kNoConductor;
  std::string reason;                  // empty when ok
  ConductorCurve line;                 // the robot's conductor (valid when ok)
  std::vector<ConductorCurve> others;  // further conductors in view
  int candidates = 0;                  // thin-structure pixels the fit looked at

  bool ok() const { return status == ConductorStatus::kOk; }
  // Position of X (rectified left frame, m) relative to the robot's conductor (ok models only).
  LinePosition Locate(const cv::Point3d& x) const;
  nlohmann::json ToJson() const;
};

// Fits the model to `disparity` (CV_32FC1, +inf invalid). `bodies`, if given, is BodyMask over
// the whole image at max_conductor_width_m (computed here otherwise). `previous` seeds the search.
ConductorModel FitConductor(const cv::Mat& disparity, const StereoGeometry& geometry,
                            const ConductorOptions& options, const cv::Mat& bodies = cv::Mat(),
                            const ConductorModel* previous = nullptr);

// Position of X relative to a curve (see ConductorModel::Locate); CurveLocator for many points.
LinePosition LocateOnCurve(const ConductorCurve& curve, const cv::Point3d& x);

// Positions of many points on one curve: each segment's frame (length, tangent, down, side) is
// worked out once instead of for every point, and the nearest segment is found through a tree of
// bounding spheres over the polyline's interior segments (a branch is skipped when its sphere is
// farther than the nearest segment so far), in O(log n) for the points near the line instead of
// O(n). conductor_test checks it bit for bit against a naive reference that tries every segment
// and works its frame out per point, on awkward curves.
class CurveLocator {
 public:
  explicit CurveLocator(const ConductorCurve& curve);
  LinePosition Locate(const cv::Point3d& x) const;

 private:
  struct Segment {
    cv::Point3d a, ab;
    double len2 = 0, len = 0, arc = 0;
    double lo = 0, hi = 0;  // clamp of the foot's fraction (the end segments extend the line)
    cv::Vec3d tangent, down, side;
  };
  // A sphere holding interior segments [first, last) (children 2i + 1, 2i + 2 of node i).
  struct Node {
    cv::Point3d centre;
    double radius = 0;
    int first = 0, last = 0;
    bool leaf = false;
  };
  struct Nearest;
  void Build(int node, int first, int last);
  void Visit(const Segment& s, int index, const cv::Point3d& x, Nearest* best) const;
  void Search(int node, const cv::Point3d& x, Nearest* best) const;

  std::vector<Segment> segments_;
  std::vector<Node> nodes_;
};

}  // namespace linesight
