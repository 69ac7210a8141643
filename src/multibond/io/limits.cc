#include "multibond/io/limits.h"

#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/model_loader.h"

namespace multibond {

namespace {

std::uint64_t InputLimits::*const kFields[] = {&InputLimits::file_bytes, &InputLimits::yaml_nodes, &InputLimits::depth,
                                              &InputLimits::instances, &InputLimits::elements, &InputLimits::bonds,
                                              &InputLimits::steps, &InputLimits::results_bytes};

}  // namespace

const std::vector<std::string>& LimitNames() {
  static const std::vector<std::string> names = {"file-size", "yaml-nodes", "depth", "instances",
                                                 "elements", "bonds", "steps", "results-size"};
  return names;
}

void SetLimit(InputLimits& limits, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument(fmt::format("--limit takes NAME=VALUE (got '{}'); names: {}", assignment, fmt::join(LimitNames(), ", ")));
  const std::string name = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  const auto& names = LimitNames();
  size_t index = names.size();
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) index = i;
  if (index == names.size()) {
    const std::string guess = DidYouMean(name, names);
    throw std::invalid_argument(fmt::format("unknown limit '{}'{}; the limits are {}", name,
                                            guess.empty() ? "" : fmt::format(" (did you mean '{}'?)", guess), fmt::join(names, ", ")));
  }
  std::uint64_t scale = 1;
  std::string digits = value;
  if (!digits.empty()) {
    const char s = digits.back();
    if (s == 'k' || s == 'K') scale = 1000;
    else if (s == 'M') scale = 1'000'000;
    else if (s == 'G') scale = 1'000'000'000;
    if (scale != 1) digits.pop_back();
  }
  const bool digits_ok = !digits.empty() && digits.size() <= 15 && digits.find_first_not_of("0123456789") == std::string::npos;
  const std::uint64_t base = digits_ok ? std::stoull(digits) : 0;
  // 15 digits and a G suffix would wrap around: a value beyond 2^62 is refused (the counters
  // compared with a limit must not overflow either).
  const bool ok = digits_ok && base <= (std::uint64_t{1} << 62) / scale;
  const std::uint64_t v = ok ? base * scale : 0;
  if (!ok || v == 0)
    throw std::invalid_argument(fmt::format("--limit {}: '{}' is not a whole number from 1 to 2^62 (a k, M or G suffix may follow)", name, value));
  limits.*kFields[index] = v;
}

std::string RaiseLimitHint(const char* name, std::uint64_t now) {
  return fmt::format("if the input is meant to be this large, raise the limit with --limit {}=N (now {})", name, now);
}

}  // namespace multibond
