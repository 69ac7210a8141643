#pragma once
// A model file of `n` bodies hung one from the next by compliant revolute joints (the first from
// the ground): the large mechanism the loader's name lookups are measured on (bench/loader_bench.cc)
// and tested with (tests/io/name_index_test.cc).

#include <string>

#include <fmt/format.h>

namespace multibond::testing {

inline std::string MechanismChainText(int n) {
  std::string text = "model: chain\nbodies:\n";
  for (int i = 0; i < n; ++i) text += fmt::format("  b{}: {{mass: 1.0, inertia: [0.1, 0.1, 0.1], position: [{}, 0, 0]}}\n", i, 0.1 * i);
  text += "joints:\n";
  for (int i = 0; i < n; ++i)
    text += fmt::format("  j{}: {{type: revolute, parent: {}, child: b{}, axis: z, translation: {{K: 1.0e6, R: 10}}, "
                        "rotation: {{K: 1.0e4, R: 1}}}}\n", i, i == 0 ? std::string("ground") : fmt::format("b{}", i - 1), i);
  return text;
}

}  // namespace multibond::testing
