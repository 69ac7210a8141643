#include "multibond/core/utf8.h"

#include <fmt/format.h>

namespace multibond {

TextProblem FindTextProblem(std::string_view text) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char b = byte(i);
    if (b < 0x80) {
      if ((b < 0x20 && b != '\t' && b != '\n' && b != '\r') || b == 0x7f)
        return {i, fmt::format("control character 0x{:02x} (YAML allows only tab, line feed and carriage return)", b)};
      ++i;
      continue;
    }
    // Lead byte: length and the range of the second byte (RFC 3629, table 3-7 of Unicode).
    std::size_t n = 0;
    unsigned char lo = 0x80, hi = 0xbf;
    if (b >= 0xc2 && b <= 0xdf) n = 2;
    else if (b == 0xe0) n = 3, lo = 0xa0;
    else if (b >= 0xe1 && b <= 0xec) n = 3;
    else if (b == 0xed) n = 3, hi = 0x9f;  // no surrogates
    else if (b >= 0xee && b <= 0xef) n = 3;
    else if (b == 0xf0) n = 4, lo = 0x90;
    else if (b >= 0xf1 && b <= 0xf3) n = 4;
    else if (b == 0xf4) n = 4, hi = 0x8f;  // nothing above U+10FFFF
    bool ok = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; ok && k < n; ++k) {
      const unsigned char c = byte(i + k);
      ok = k == 1 ? (c >= lo && c <= hi) : (c >= 0x80 && c <= 0xbf);
    }
    if (!ok) return {i, fmt::format("byte 0x{:02x} is not part of valid UTF-8", b)};
    i += n;
  }
  return {};
}

}  // namespace multibond
