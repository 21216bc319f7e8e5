// systems/union_find.hpp: the sets and their numbering depend only on which pairs are joined.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include "systems/union_find.hpp"

using perifx::systems::UnionFind;

TEST_CASE("UnionFind: roots are the smallest index and labels follow them, whatever the join order") {
  // 8 items; sets {0, 3, 5}, {1}, {2, 7}, {4, 6}.
  std::array<std::pair<std::uint32_t, std::uint32_t>, 4> joins{{{5, 3}, {7, 2}, {3, 0}, {6, 4}}};
  const std::vector<std::uint32_t> roots{0, 1, 2, 0, 4, 0, 4, 2};
  const std::vector<std::uint32_t> labels{0, 1, 2, 0, 3, 0, 3, 2};  // numbered by smallest member
  std::sort(joins.begin(), joins.end());
  do {
    std::vector<std::uint32_t> parent, label;
    UnionFind sets(parent, 8);
    for (const auto& [a, b] : joins) sets.unite(a, b);
    CHECK(sets.label(label) == 4);
    CHECK(parent == roots);
    CHECK(label == labels);
  } while (std::next_permutation(joins.begin(), joins.end()));
}

TEST_CASE("UnionFind: no joins leaves n singleton sets; one chain leaves one") {
  std::vector<std::uint32_t> parent, label;
  {
    UnionFind sets(parent, 5);
    CHECK(sets.label(label) == 5);
    CHECK(label == std::vector<std::uint32_t>{0, 1, 2, 3, 4});
  }
  {
    UnionFind sets(parent, 5);
    for (std::uint32_t a = 4; a > 0; --a) sets.unite(a, a - 1);
    CHECK(sets.flatten() == 1);
    CHECK(sets.label(label) == 1);
    CHECK(label == std::vector<std::uint32_t>(5, 0));
  }
}
