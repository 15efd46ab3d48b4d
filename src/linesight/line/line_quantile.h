// The q-quantile of a set of values, shared by the line stages.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace linesight::line_detail {

// q in [0, 1]: the value of rank round(q (n - 1)) (the values are copied); 0 for no values.
inline double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k =
      std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace linesight::line_detail
