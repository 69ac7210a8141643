#pragma once
/// \file
/// UTF-8 checks for text that comes from outside (model files, paths, command lines): JSON, HTML
/// and terminals need valid UTF-8, and a byte that is not must be said or shown, never passed on.

#include <cstddef>
#include <string>
#include <string_view>

namespace multibond {

/// The offset of the first byte that does not belong to valid UTF-8 (overlong forms, surrogates
/// and code points above U+10FFFF are invalid), or std::string_view::npos when all of it is valid.
std::size_t FindInvalidUtf8(std::string_view text);

/// `text` with every byte that is not valid UTF-8 written as \xNN (and a backslash that could be
/// read as such an escape as \\): valid text comes back unchanged, and the original bytes can be
/// recovered from the result.
std::string EscapeInvalidUtf8(std::string_view text);

}  // namespace multibond
