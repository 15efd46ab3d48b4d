// Drawings for people: labelled boxes on an image (the demo's ranged view, the base station's
// annotated video stream).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace linesight {

// Draws every box, then its label where it overlaps no label drawn before and stays inside the
// image: above the box, below it, right of it, or slid down in steps from above it; a leader line
// joins a label that does not touch its box.
void DrawLabelledBoxes(cv::Mat& image, const std::vector<cv::Rect>& boxes,
                       const std::vector<std::string>& labels, const cv::Scalar& colour);

}  // namespace linesight
