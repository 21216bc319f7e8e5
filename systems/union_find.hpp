// Union-find (disjoint sets) over the indices 0..n−1, written once for every connected-components
// question in perifx: fragments of the alive-bond graph (fragments.cpp), the one-piece check of a
// tet mesh (engine/geometry/mesh_checks.cpp) and the tet groups around a vertex or an edge when the
// embedded mesh splits (mesh_split.cpp). A plain algorithm, no components: engine/geometry may
// include it.
//
// The sets live in a caller-owned array, parent (n entries; parent[a] == a for a root), so a caller
// that wants the ids as output can hand in its output array and pay no copy. Union keeps the smaller
// root, so every set's root is its smallest index: the result depends only on which pairs are joined,
// never on the order, and after flatten() parent[a] is that smallest index for every a. find() halves
// paths as it walks (parent[a] ← parent[parent[a]]).
#pragma once
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace perifx::systems {

class UnionFind {
 public:
  // Resets `parent` to n singleton sets; the object refers to it (it must outlive this object).
  UnionFind(std::vector<std::uint32_t>& parent, std::size_t n) : parent_(parent) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0u);
  }

  // Root (smallest index) of a's set.
  std::uint32_t find(std::uint32_t a) {
    while (parent_[a] != a) {
      parent_[a] = parent_[parent_[a]];  // path halving
      a = parent_[a];
    }
    return a;
  }

  // Joins the sets of a and b; the smaller root becomes the root of both.
  void unite(std::uint32_t a, std::uint32_t b) {
    const std::uint32_t ra = find(a), rb = find(b);
    if (ra < rb) parent_[rb] = ra;
    else if (rb < ra) parent_[ra] = rb;
  }

  // Points every index straight at its root and returns the number of sets. One ascending pass is
  // enough: a root is smaller than every member, so parent[parent[a]] is already final when a is reached.
  std::size_t flatten() {
    std::size_t count = 0;
    for (std::uint32_t a = 0; a < parent_.size(); ++a) {
      parent_[a] = parent_[parent_[a]];
      count += parent_[a] == a;
    }
    return count;
  }

  // Flattens, then numbers the sets 0, 1, … in the order of their smallest index and writes each
  // index's set number to `label` (resized to n; it must not be `parent`). Returns the number of sets.
  std::uint32_t label(std::vector<std::uint32_t>& label) {
    flatten();
    label.resize(parent_.size());
    std::uint32_t count = 0;
    for (std::uint32_t a = 0; a < parent_.size(); ++a) label[a] = parent_[a] == a ? count++ : label[parent_[a]];
    return count;
  }

 private:
  std::vector<std::uint32_t>& parent_;
};

}  // namespace perifx::systems
