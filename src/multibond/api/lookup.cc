#include "multibond/api/lookup.h"

#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/model_loader.h"

namespace multibond {

void ThrowUnknownName(const char* what, std::string_view name, const std::vector<std::string>& known) {
  const std::string guess = DidYouMean(std::string(name), known);
  throw std::invalid_argument(fmt::format("no {} called '{}'{}", what, name, guess.empty() ? "" : fmt::format(" (did you mean '{}'?)", guess)));
}

}  // namespace multibond
