#include "multibond/io/model_parameters.h"

#include <cstdlib>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/core/identifier.h"

namespace multibond {

bool ModelParameter::is_formula() const {
  const char* begin = text.c_str();
  char* end = nullptr;
  (void)std::strtod(begin, &end);
  return text.empty() || end != begin + text.size();
}

ParameterOverride ParseParameterAssignment(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument(fmt::format("'{}' is not NAME=VALUE (e.g. --set L=0.5 or --set L=2*L0)", PrintableExcerpt(assignment)));
  ParameterOverride o{assignment.substr(0, eq), assignment.substr(eq + 1)};
  auto trim = [](std::string s) {
    const auto a = s.find_first_not_of(" \t"), z = s.find_last_not_of(" \t");
    return a == std::string::npos ? std::string() : s.substr(a, z - a + 1);
  };
  o.name = trim(o.name);
  o.value = trim(o.value);
  if (o.name.empty()) throw std::invalid_argument(fmt::format("'{}' names no parameter: write NAME=VALUE", PrintableExcerpt(assignment)));
  if (o.value.empty())
    throw std::invalid_argument(fmt::format("'{}' gives no value: write NAME=VALUE, VALUE a number or a formula of parameters",
                                            PrintableExcerpt(assignment)));
  return o;
}

bool IsReservedInFormulas(const std::string& name) {
  return name == "t" || name == "pi" || name == "q" || name == "p" || name == "e" || name == "f";
}

}  // namespace multibond
