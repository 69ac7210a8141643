#pragma once
/// \file
/// The API's answer to a name it does not know: std::invalid_argument naming what was looked for,
/// with a did-you-mean from the names it knows.

#include <string>
#include <string_view>
#include <vector>

namespace multibond {

[[noreturn]] void ThrowUnknownName(const char* what, std::string_view name, const std::vector<std::string>& known);

}  // namespace multibond
