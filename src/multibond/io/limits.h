#pragma once
/// \file
/// Bounds on untrusted input. A model file or a results folder may come from anyone: every size
/// that could make multibond run out of memory or time is bounded, and a bound that is exceeded is
/// a located error that names the limit and how to raise it (`--limit NAME=VALUE` on the command
/// line, or the field of InputLimits in the C++ API).

#include <cstdint>
#include <string>
#include <vector>

namespace multibond {

struct InputLimits {
  std::uint64_t file_bytes = 16u << 20;      ///< "file-size": a model file's size in bytes
  std::uint64_t yaml_nodes = 1'000'000;      ///< "yaml-nodes": YAML nodes, every alias counted as the nodes it stands for
  std::uint64_t depth = 64;                  ///< "depth": nesting of YAML collections, and of submodels in submodels
  std::uint64_t instances = 100'000;         ///< "instances": submodel instances, nested ones included
  std::uint64_t elements = 1'000'000;        ///< "elements": elements of the expanded bond graph
  std::uint64_t bonds = 1'000'000;           ///< "bonds": bonds of the expanded bond graph
  std::uint64_t steps = 100'000'000;         ///< "steps": fixed steps (or output rows) a run may ask for
  std::uint64_t results_bytes = 4ull << 30;  ///< "results-size": a results.csv that `plot` reads
};

/// The names accepted by SetLimit, in the order of the fields.
const std::vector<std::string>& LimitNames();

/// Applies "NAME=VALUE" (VALUE a whole number >= 1, with an optional k, M or G suffix: 16M).
/// Throws std::invalid_argument saying what is wrong, with a did-you-mean for a misspelt name.
void SetLimit(InputLimits& limits, const std::string& assignment);

/// The hint of an exceeded limit: "raise it with --limit NAME=VALUE (now VALUE)".
std::string RaiseLimitHint(const char* name, std::uint64_t now);

}  // namespace multibond
