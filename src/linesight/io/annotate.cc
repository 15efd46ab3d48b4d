#include "linesight/io/annotate.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace linesight {

void DrawLabelledBoxes(cv::Mat& image, const std::vector<cv::Rect>& boxes,
                       const std::vector<std::string>& labels, const cv::Scalar& colour) {
  for (const cv::Rect& box : boxes) cv::rectangle(image, box, colour, 2);
  const cv::Rect frame(0, 0, image.cols, image.rows);
  std::vector<cv::Rect> placed;
  for (size_t i = 0; i < boxes.size() && i < labels.size(); ++i) {
    const cv::Rect& box = boxes[i];
    int baseline = 0;
    const cv::Size text = cv::getTextSize(labels[i], cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline);
    const cv::Size size(text.width + 4, text.height + baseline + 3);
    auto clamp_into_frame = [&](cv::Point p) {
      return cv::Point(std::clamp(p.x, 0, std::max(0, image.cols - size.width)),
                       std::clamp(p.y, 0, std::max(0, image.rows - size.height)));
    };
    std::vector<cv::Point> candidates = {
        {box.x, box.y - size.height - 2}, {box.x, box.br().y + 2}, {box.br().x + 4, box.y}};
    for (int step = 1; step < 40; ++step) {
      candidates.push_back({box.x, box.y - size.height - 2 + step * (size.height + 2)});
      candidates.push_back({box.x, box.y - size.height - 2 - step * (size.height + 2)});
    }
    cv::Rect chosen(clamp_into_frame(candidates.front()), size);
    for (const cv::Point& candidate : candidates) {
      const cv::Rect r(clamp_into_frame(candidate), size);
      const bool free = std::none_of(placed.begin(), placed.end(),
                                     [&](const cv::Rect& other) { return (r & other).area() > 0; });
      if (free && (r & frame) == r) {
        chosen = r;
        break;
      }
    }
    placed.push_back(chosen);
    const cv::Rect grown(box.x - 3, box.y - 3, box.width + 6, box.height + 6);
    if ((chosen & grown).area() == 0) {
      const cv::Point label_anchor(chosen.x + 2, chosen.y < box.y ? chosen.br().y : chosen.y);
      cv::line(image, label_anchor, cv::Point(box.x, chosen.y < box.y ? box.y : box.br().y), colour,
               1, cv::LINE_AA);
    }
    cv::rectangle(image, chosen, cv::Scalar(0, 0, 0), cv::FILLED);
    cv::putText(image, labels[i], cv::Point(chosen.x + 2, chosen.y + text.height + 1),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
  }
}

}  // namespace linesight
