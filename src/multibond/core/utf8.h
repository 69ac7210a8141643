#pragma once
/// \file
/// Text checks for untrusted input: a model file's bytes must be UTF-8 (results, run.json and
/// messages carry its text), without the control characters YAML does not allow.

#include <cstddef>
#include <string>
#include <string_view>

namespace multibond {

struct TextProblem {
  std::size_t offset = std::string_view::npos;  ///< of the first bad byte; npos: the text is fine
  std::string what;                             ///< e.g. "byte 0xff is not UTF-8"
  bool found() const { return offset != std::string_view::npos; }
};

/// The first byte of `text` that is not part of well-formed UTF-8 (no overlong forms, no
/// surrogates, nothing above U+10FFFF), or a control character other than tab, line feed and
/// carriage return (NUL, ESC, DEL ...: YAML allows none of them).
TextProblem FindTextProblem(std::string_view text);

}  // namespace multibond
