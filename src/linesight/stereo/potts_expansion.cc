// The α-expansion solver of the gc matcher (detail::PottsExpansion, graph_cut.h): the Potts energy
// and one exact expansion move per Boykov–Kolmogorov max-flow on a graph built once per view.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <boost/graph/boykov_kolmogorov_max_flow.hpp>
#include <boost/graph/compressed_sparse_row_graph.hpp>
#include <boost/property_map/property_map.hpp>

#include "linesight/core/error.h"
#include "linesight/stereo/graph_cut.h"

namespace linesight {

namespace detail {

int64_t PottsEnergy(int width, int height, const std::vector<int32_t>& weight_right,
                    const std::vector<int32_t>& weight_down, const std::vector<int32_t>& labels,
                    const std::vector<int32_t>& data_costs) {
  const size_t n = static_cast<size_t>(width) * height;
  LS_CHECK(weight_right.size() == n && weight_down.size() == n && labels.size() == n &&
           data_costs.size() == n);
  int64_t energy = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t p = static_cast<size_t>(y) * width + x;
      energy += data_costs[p];
      if (x + 1 < width && labels[p] != labels[p + 1]) energy += weight_right[p];
      if (y + 1 < height && labels[p] != labels[p + width]) energy += weight_down[p];
    }
  }
  return energy;
}

// Flat graph for Boost's Boykov–Kolmogorov solver: pixels 0..n-1, source n, sink n+1. Every edge
// has its reverse edge (Boost's residual graph needs it). Per pixel p the out-edges are p→sink,
// p→source, then p's grid edges.
using CapacityType = int64_t;  // the total flow of a large image exceeds int32
using CsrGraph =
    boost::compressed_sparse_row_graph<boost::directedS, boost::no_property, boost::no_property,
                                       boost::no_property, uint32_t, uint32_t>;
using GraphEdge = boost::graph_traits<CsrGraph>::edge_descriptor;

struct PottsExpansion::Graph {
  CsrGraph graph;
  uint32_t source = 0;
  uint32_t sink = 0;
  std::vector<GraphEdge> reverse;      // by edge index
  std::vector<CapacityType> capacity;  // by edge index
  std::vector<CapacityType> residual;  // by edge index
  std::vector<GraphEdge> predecessor;  // by vertex
  std::vector<boost::default_color_type> color;
  std::vector<long> distance;
  // Edge indices per pixel p.
  std::vector<uint32_t> from_source;  // source → p (cut when p takes alpha)
  std::vector<uint32_t> to_sink;      // p → sink (cut when p keeps its label)
  std::vector<uint32_t> right;        // p → p + 1
  std::vector<uint32_t> right_back;   // p + 1 → p
  std::vector<uint32_t> down;         // p → p + width
  std::vector<uint32_t> down_back;    // p + width → p
  std::vector<int64_t> keep_cost;     // scratch: cost of "keep" (x_p = 0) per pixel
  std::vector<int64_t> switch_cost;   // scratch: cost of "take alpha" (x_p = 1) per pixel
};

PottsExpansion::PottsExpansion(int width, int height, std::vector<int32_t> weight_right,
                               std::vector<int32_t> weight_down)
    : width_(width),
      height_(height),
      weight_right_(std::move(weight_right)),
      weight_down_(std::move(weight_down)),
      graph_(std::make_unique<Graph>()) {
  LS_CHECK(width >= 1 && height >= 1);
  const uint32_t n = static_cast<uint32_t>(width) * static_cast<uint32_t>(height);
  LS_CHECK(weight_right_.size() == n && weight_down_.size() == n);
  Graph& g = *graph_;
  g.source = n;
  g.sink = n + 1;
  g.from_source.assign(n, 0);
  g.to_sink.assign(n, 0);
  g.right.assign(n, 0);
  g.right_back.assign(n, 0);
  g.down.assign(n, 0);
  g.down_back.assign(n, 0);
  std::vector<uint32_t> source_back(n), sink_back(n);

  // Edges sorted by source vertex, so that an edge's index is its position in this list.
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(static_cast<size_t>(n) * 8);
  auto add = [&](uint32_t from, uint32_t to) {
    edges.emplace_back(from, to);
    return static_cast<uint32_t>(edges.size() - 1);
  };
  const uint32_t w = static_cast<uint32_t>(width);
  for (uint32_t p = 0; p < n; ++p) {
    const uint32_t x = p % w;
    g.to_sink[p] = add(p, g.sink);
    source_back[p] = add(p, g.source);
    if (x + 1 < w) g.right[p] = add(p, p + 1);
    if (x > 0) g.right_back[p - 1] = add(p, p - 1);
    if (p + w < n) g.down[p] = add(p, p + w);
    if (p >= w) g.down_back[p - w] = add(p, p - w);
  }
  for (uint32_t p = 0; p < n; ++p) g.from_source[p] = add(g.source, p);
  for (uint32_t p = 0; p < n; ++p) sink_back[p] = add(g.sink, p);

  g.graph = CsrGraph(boost::edges_are_sorted, edges.begin(), edges.end(), n + 2);
  const auto edge_index = get(boost::edge_index, g.graph);
  std::vector<GraphEdge> by_index(edges.size());
  for (uint32_t v = 0; v < n + 2; ++v) {
    for (auto [it, end] = out_edges(v, g.graph); it != end; ++it) {
      const uint32_t i = get(edge_index, *it);
      LS_CHECK(i < edges.size() && edges[i].first == v && edges[i].second == target(*it, g.graph));
      by_index[i] = *it;
    }
  }
  g.reverse.resize(edges.size());
  auto pair_up = [&](uint32_t a, uint32_t b) {
    g.reverse[a] = by_index[b];
    g.reverse[b] = by_index[a];
  };
  for (uint32_t p = 0; p < n; ++p) {
    pair_up(g.from_source[p], source_back[p]);
    pair_up(g.to_sink[p], sink_back[p]);
    if (p % w + 1 < w) pair_up(g.right[p], g.right_back[p]);
    if (p + w < n) pair_up(g.down[p], g.down_back[p]);
  }
  g.capacity.assign(edges.size(), 0);
  g.residual.assign(edges.size(), 0);
  g.predecessor.resize(n + 2);
  g.color.resize(n + 2);
  g.distance.resize(n + 2);
  g.keep_cost.resize(n);
  g.switch_cost.resize(n);
}

PottsExpansion::~PottsExpansion() = default;

void PottsExpansion::SetLabeling(std::vector<int32_t> labels, std::vector<int32_t> data_costs) {
  const size_t n = static_cast<size_t>(width_) * height_;
  LS_CHECK(labels.size() == n && data_costs.size() == n);
  labels_ = std::move(labels);
  data_costs_ = std::move(data_costs);
}

int64_t PottsExpansion::Energy() const {
  return PottsEnergy(width_, height_, weight_right_, weight_down_, labels_, data_costs_);
}

int PottsExpansion::Expand(int32_t alpha, const int32_t* alpha_costs) {
  Graph& g = *graph_;
  const int n = width_ * height_;
  LS_CHECK(static_cast<int>(labels_.size()) == n);
  std::fill(g.capacity.begin(), g.capacity.end(), 0);
  // Binary variable per pixel: x_p = 0 keeps labels_[p] (source side), x_p = 1 takes alpha (sink
  // side). Pixels already labelled alpha do not change; their pairwise terms become unary terms of
  // their neighbours.
  for (int p = 0; p < n; ++p) {
    g.keep_cost[p] = data_costs_[p];
    g.switch_cost[p] = alpha_costs[p];
  }
  // Kolmogorov–Zabih construction of one Potts pair term w·[f_p ≠ f_q] of the move (p, q both
  // free):
  //   f_p == f_q: E(0,0) = 0, E(0,1) = E(1,0) = w, E(1,1) = 0 → edges p→q and q→p of capacity w;
  //   f_p != f_q: E(0,0) = E(0,1) = E(1,0) = w, E(1,1) = 0   → edge p→q of capacity w + w on "q
  //   keeps".
  auto pair_term = [&](int p, int q, int32_t w, uint32_t forward, uint32_t backward) {
    if (w == 0) return;
    const bool p_fixed = labels_[p] == alpha;
    const bool q_fixed = labels_[q] == alpha;
    if (p_fixed && q_fixed) return;
    if (p_fixed) {
      g.keep_cost[q] += w;
    } else if (q_fixed) {
      g.keep_cost[p] += w;
    } else if (labels_[p] == labels_[q]) {
      g.capacity[forward] = w;
      g.capacity[backward] = w;
    } else {
      g.capacity[forward] = w;
      g.keep_cost[q] += w;
    }
  };
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const int p = y * width_ + x;
      if (x + 1 < width_) pair_term(p, p + 1, weight_right_[p], g.right[p], g.right_back[p]);
      if (y + 1 < height_) pair_term(p, p + width_, weight_down_[p], g.down[p], g.down_back[p]);
    }
  }
  for (int p = 0; p < n; ++p) {
    if (labels_[p] == alpha) continue;
    const int64_t common = std::min(g.keep_cost[p], g.switch_cost[p]);
    g.capacity[g.from_source[p]] =
        g.switch_cost[p] - common;  // cut when p is on the sink side (takes alpha)
    g.capacity[g.to_sink[p]] = g.keep_cost[p] - common;  // cut when p is on the source side (keeps)
  }

  const auto edge_index = get(boost::edge_index, g.graph);
  const auto vertex_index = get(boost::vertex_index, g.graph);
  boost::boykov_kolmogorov_max_flow(
      g.graph, boost::make_iterator_property_map(g.capacity.begin(), edge_index),
      boost::make_iterator_property_map(g.residual.begin(), edge_index),
      boost::make_iterator_property_map(g.reverse.begin(), edge_index),
      boost::make_iterator_property_map(g.predecessor.begin(), vertex_index),
      boost::make_iterator_property_map(g.color.begin(), vertex_index),
      boost::make_iterator_property_map(g.distance.begin(), vertex_index), vertex_index, g.source,
      g.sink);

  // At termination the source search tree (black) is exactly the set reachable from the source in
  // the residual graph, so (black, rest) is a minimum cut: black pixels keep their label, all
  // others take alpha.
  int switched = 0;
  for (int p = 0; p < n; ++p) {
    if (labels_[p] == alpha || g.color[p] == boost::black_color) continue;
    labels_[p] = alpha;
    data_costs_[p] = alpha_costs[p];
    ++switched;
  }
  return switched;
}

}  // namespace detail

}  // namespace linesight
