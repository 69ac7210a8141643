#include "multibond/core/diagnostic_codes.h"

namespace multibond::codes {

const CodeInfo* Find(std::string_view code) {
  for (const CodeInfo& c : kCatalogue)
    if (c.code == code) return &c;
  return nullptr;
}

std::string_view LimitCode(std::string_view limit) {
  constexpr std::string_view kPrefix = "limit.";
  for (const CodeInfo& c : kCatalogue)
    if (c.code.size() == kPrefix.size() + limit.size() && c.code.starts_with(kPrefix) && c.code.ends_with(limit)) return c.code;
  return {};
}

Outcome OutcomeOf(std::string_view code) {
  const CodeInfo* c = Find(code);
  return c ? c->outcome : Outcome::kModelError;
}

}  // namespace multibond::codes
