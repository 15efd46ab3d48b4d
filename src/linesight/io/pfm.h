// PFM (Portable Float Map) as Middlebury uses it: header "Pf" (grey) or "PF" (colour), width
// height, scale; the *sign* of the scale gives the byte order (negative = little-endian), its
// magnitude is ignored; rows are stored bottom-to-top; +inf marks unknown disparity.
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

namespace linesight {

// Returns CV_32FC1 (for "Pf") or CV_32FC3 (for "PF", channels in file order). Throws InputError
// naming the file and what is wrong (bad magic, bad size, truncated data, ...).
cv::Mat ReadPfm(const std::filesystem::path& path);

// Writes CV_32FC1 or CV_32FC3 as little-endian PFM (scale -1), atomically.
void WritePfm(const std::filesystem::path& path, const cv::Mat& image);

// Parses PFM bytes already in memory (used by ReadPfm and by the fuzzer). `name` is used in
// messages.
cv::Mat DecodePfm(const std::string& bytes, const std::string& name);
std::string EncodePfm(const cv::Mat& image);

}  // namespace linesight
