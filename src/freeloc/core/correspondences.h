// Correspondences between a reference and a query image, the one form every matcher hands to the solvers: pixel
// pairs in original-image pixels (x = column, y = row; docs/architecture.md §2), reference first, optionally with
// the instance each came from. Light header (Eigen only). Core vocabulary: matching makes them, pose/ solves on
// them (matching::Correspondences is this type).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace freeloc {

struct Correspondences {
  std::vector<Eigen::Vector2d> ref, query;
  std::vector<int> source;  // optional, per row: the instance that gave it (−1: global matching); empty when unknown
  size_t size() const { return ref.size(); }
  // As (x_ref, y_ref, x_query, y_query) rows — the correspondence-file and precomputed-matcher form — and back.
  std::vector<Eigen::Vector4d> Rows() const {
    std::vector<Eigen::Vector4d> rows;
    rows.reserve(size());
    for (size_t i = 0; i < size(); ++i) rows.emplace_back(ref[i].x(), ref[i].y(), query[i].x(), query[i].y());
    return rows;
  }
  static Correspondences FromRows(const std::vector<Eigen::Vector4d>& rows) {
    Correspondences c;
    for (const auto& r : rows) {
      c.ref.emplace_back(r(0), r(1));
      c.query.emplace_back(r(2), r(3));
    }
    return c;
  }
};

}  // namespace freeloc
