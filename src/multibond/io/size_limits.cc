#include "multibond/io/size_limits.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>

#include <fmt/format.h>

#include "multibond/core/diagnostic_codes.h"

namespace multibond {

namespace {

/// What a scope expands to: submodel instances (nested ones included), the depth of their
/// nesting, elements and bonds. Saturates at kCountCap.
struct Expansion {
  std::uint64_t instances = 0, depth = 0, elements = 0, bonds = 0;
};
constexpr std::uint64_t kCountCap = std::uint64_t{1} << 62;
std::uint64_t Add(std::uint64_t a, std::uint64_t b) { return std::min(kCountCap, a + std::min(b, kCountCap)); }

Expansion Expand(const YAML::Node& scope, const std::map<std::string, SubmodelDef>& submodels, std::map<std::string, Expansion>& memo,
                 std::set<std::string>& visiting) {
  Expansion x;
  const YAML::Node elements = scope["elements"];
  if (elements.IsMap())
    for (const auto& kv : elements) {
      const YAML::Node type = kv.second.IsMap() ? kv.second["type"] : YAML::Node();
      const auto def = type && type.IsScalar() ? submodels.find(type.Scalar()) : submodels.end();
      if (def == submodels.end()) {
        x.elements = Add(x.elements, 1);
        continue;
      }
      if (visiting.count(def->first)) continue;  // a submodel that contains itself: said by Instantiate
      if (!memo.count(def->first)) {
        visiting.insert(def->first);
        memo[def->first] = Expand(def->second.node, submodels, memo, visiting);
        visiting.erase(def->first);
      }
      const Expansion& inner = memo[def->first];
      x.instances = Add(x.instances, Add(inner.instances, 1));
      x.depth = std::max(x.depth, Add(inner.depth, 1));
      x.elements = Add(x.elements, inner.elements);
      x.bonds = Add(x.bonds, inner.bonds);
    }
  if (scope["bonds"].IsSequence()) x.bonds = Add(x.bonds, scope["bonds"].size());
  return x;
}

}  // namespace

/// The limit `name` (InputLimits) exceeded by `found` (kCountCap: "more than `limit`").
void SizeLimits::LimitError(const char* name, const SourceLocation& where, std::uint64_t found, std::uint64_t limit, const std::string& what) {
  const std::string count = found >= kCountCap ? fmt::format("more than {}", limit) : fmt::format("{}", found);
  sink_.Error(std::string(codes::LimitCode(name)), where, "", fmt::format("limit '{}' exceeded: {} {} (at most {})", name, count, what, limit),
              RaiseLimitHint(name, limit));
}

/// Counts what the model's submodels expand to, before any is expanded. False if a limit is exceeded.
bool SizeLimits::CheckExpansion(const YAML::Node& root) {
  if (cx_.submodels.empty()) return true;
  std::map<std::string, Expansion> memo;
  std::set<std::string> visiting;
  const Expansion x = Expand(root, cx_.submodels, memo, visiting);
  const SourceLocation where = root["elements"] ? Loc(root["elements"]) : SourceLocation{cx_.file, 1, 1};
  bool ok = true;
  if (x.instances > cx_.limits.instances) ok = false, LimitError("instances", where, x.instances, cx_.limits.instances, "submodel instances, nested ones included");
  if (x.depth > cx_.limits.depth) ok = false, LimitError("depth", where, x.depth, cx_.limits.depth, "submodels nested in submodels");
  if (x.elements > cx_.limits.elements) ok = false, LimitError("elements", where, x.elements, cx_.limits.elements, "elements once the submodels are expanded");
  if (x.bonds > cx_.limits.bonds) ok = false, LimitError("bonds", where, x.bonds, cx_.limits.bonds, "bonds once the submodels are expanded");
  return ok;
}

/// The expanded graph (mechanism parts included) within the element and bond limits.
void SizeLimits::CheckGraphSize(const YAML::Node& root) {
  const SourceLocation where = root["bodies"] ? Loc(root["bodies"]) : root["elements"] ? Loc(root["elements"]) : SourceLocation{cx_.file, 1, 1};
  const auto elements = static_cast<std::uint64_t>(graph_.num_elements()), bonds = static_cast<std::uint64_t>(graph_.num_bonds());
  if (elements > cx_.limits.elements) LimitError("elements", where, elements, cx_.limits.elements, "elements in the expanded bond graph");
  if (bonds > cx_.limits.bonds) LimitError("bonds", where, bonds, cx_.limits.bonds, "bonds in the expanded bond graph");
}

}  // namespace multibond
