#pragma once
/// \file
/// UTF-8 checks for text that comes from outside (model files, paths, command lines): JSON, HTML
/// and terminals need valid UTF-8, and a byte that is not must be said or shown, never passed on.

#include <cstddef>
#include <string>
#include <string_view>

namespace multibond {

/// The offset of the first byte that does not belong to well-formed UTF-8 (overlong forms,
/// surrogates and code points above U+10FFFF are not), or std::string_view::npos.
std::size_t FindInvalidUtf8(std::string_view text);

/// `text` with every byte that is not valid UTF-8 written as \xNN (and, when there is one, each
/// backslash as \\): valid text comes back unchanged, and the original bytes can be recovered.
std::string EscapeInvalidUtf8(std::string_view text);

struct TextProblem {
  std::size_t offset = std::string_view::npos;  ///< of the first bad byte; npos: the text is fine
  std::string what;                             ///< e.g. "byte 0xff is not part of valid UTF-8"
  bool found() const { return offset != std::string_view::npos; }
};

/// For a model file's text: the first byte that is not well-formed UTF-8, or a control character
/// other than tab, line feed and carriage return (NUL, ESC, DEL ...: YAML allows none of them).
TextProblem FindTextProblem(std::string_view text);

}  // namespace multibond
