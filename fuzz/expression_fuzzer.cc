// libFuzzer entry point for the parser of formulas (core/expression.h). Not run by scripts/fuzz;
// after scripts/fuzz has configured build/fuzz:
//   cmake --build build/fuzz --target expression_fuzzer
//   build/fuzz/fuzz/expression_fuzzer -max_total_time=60 -max_len=4200
//
// Any text must give a tree or a located error, never a crash or a sanitizer report; a tree must
// format to text that parses back to the same text, and evaluate without an exception when every
// name is given.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "multibond/core/expression.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace multibond::expr;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const ParseResult r = Parse(text);
  if (!r.root) {
    if (!r.error || r.error->message.empty() || r.error->offset < 0 || static_cast<size_t>(r.error->offset) > size)
      __builtin_trap();
    return 0;
  }
  const std::string formatted = Format(*r.root);
  const ParseResult again = Parse(formatted);
  // A formula of at most 4096 bytes can format longer (1e5 -> 100000): only then may it not parse.
  if (!again.root) {
    if (formatted.size() <= static_cast<size_t>(kMaxFormulaBytes)) __builtin_trap();
    return 0;
  }
  if (Format(*again.root) != formatted) __builtin_trap();
  (void)Names(*r.root);
  (void)Evaluate(*r.root, [](const std::string&) -> std::optional<double> { return 1.0; });
  return 0;
}
