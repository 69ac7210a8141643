#include "multibond/io/safe_text.h"

#include <fmt/format.h>

namespace multibond {

namespace {

constexpr std::string_view kReplacement = "\xef\xbf\xbd";  // U+FFFD

/// Length of the UTF-8 sequence at s[i] (its code point in `cp`), or 0 when the bytes there are
/// not one (a stray continuation byte, a truncated sequence, an overlong form, a surrogate, or a
/// code point above U+10FFFF).
size_t DecodeUtf8(std::string_view s, size_t i, char32_t* cp) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) {
    *cp = b0;
    return 1;
  }
  size_t n = 0;
  char32_t c = 0, min = 0;
  if ((b0 & 0xe0) == 0xc0) n = 2, c = b0 & 0x1f, min = 0x80;
  else if ((b0 & 0xf0) == 0xe0) n = 3, c = b0 & 0x0f, min = 0x800;
  else if ((b0 & 0xf8) == 0xf0) n = 4, c = b0 & 0x07, min = 0x10000;
  else return 0;
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    c = (c << 6) | (byte(i + k) & 0x3f);
  }
  if (c < min || c > 0x10ffff || (c >= 0xd800 && c <= 0xdfff)) return 0;
  *cp = c;
  return n;
}

bool IsControl(char32_t c) { return c < 0x20 || (c >= 0x7f && c <= 0x9f); }

/// Calls `emit(code point, its bytes)` for each character of `s`; a byte that does not start a
/// UTF-8 sequence is passed as `invalid(byte)`.
template <class Emit, class Invalid>
void ForEachChar(std::string_view s, Emit&& emit, Invalid&& invalid) {
  for (size_t i = 0; i < s.size();) {
    char32_t c = 0;
    const size_t n = DecodeUtf8(s, i, &c);
    if (n == 0) {
      invalid(static_cast<unsigned char>(s[i]));
      ++i;
      continue;
    }
    emit(c, s.substr(i, n));
    i += n;
  }
}

/// The skeleton of the escaping functions: valid UTF-8 with control characters and invalid bytes
/// as U+FFFD, except where `special` (called with each character) appends something else and
/// returns true.
template <class Special>
std::string Map(std::string_view s, Special&& special) {
  std::string out;
  out.reserve(s.size());
  ForEachChar(
      s,
      [&](char32_t c, std::string_view bytes) {
        if (special(c, out)) return;
        out += IsControl(c) ? kReplacement : bytes;
      },
      [&](unsigned char) { out += kReplacement; });
  return out;
}

/// `open`, `body`, `close` in one string (GCC 12 warns, wrongly, on "x" + std::string + "x").
std::string Enclose(char open, const std::string& body, char close) {
  std::string out(1, open);
  out += body;
  out += close;
  return out;
}

}  // namespace

std::string ValidUtf8(std::string_view s) {
  return Map(s, [](char32_t c, std::string& out) {
    if (c != '\n' && c != '\t') return false;
    out += static_cast<char>(c);
    return true;
  });
}

namespace {

/// The five characters of markup (HTML, and DOT's HTML-like labels) as entities; false for others.
bool EscapeMarkup(char32_t c, std::string& out) {
  switch (c) {
    case '&': out += "&amp;"; return true;
    case '<': out += "&lt;"; return true;
    case '>': out += "&gt;"; return true;
    case '"': out += "&quot;"; return true;
    case '\'': out += "&#39;"; return true;
    default: return false;
  }
}

}  // namespace

std::string HtmlEscape(std::string_view s) {
  return Map(s, [](char32_t c, std::string& out) {
    if (EscapeMarkup(c, out)) return true;
    if (c != '\n' && c != '\t') return false;
    out += static_cast<char>(c);
    return true;
  });
}

std::string GnuplotString(std::string_view s) {
  return Enclose('\'', Map(s, [](char32_t c, std::string& out) {
                   if (c == '\'') out += "''";
                   else if (IsControl(c)) out += ' ';
                   else if (c == '`') out += kReplacement;
                   else return false;
                   return true;
                 }), '\'');
}

std::string GnuplotLiteralText(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    if (c == '^' || c == '_' || c == '{' || c == '}' || c == '&' || c == '~' || c == '@' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}

std::string GnuplotComment(std::string_view s) {
  std::string out = Map(s, [](char32_t c, std::string& out) {
    if (IsControl(c)) out += ' ';
    else if (c == '`') out += kReplacement;
    else return false;
    return true;
  });
  while (!out.empty() && out.back() == '\\') out.pop_back();
  return out;
}

std::string DotString(std::string_view s) {
  return Enclose('"', Map(s, [](char32_t c, std::string& out) {
                   if (c == '"' || c == '\\') {
                     out += '\\';
                     out += static_cast<char>(c);
                   } else if (c == '\n') {
                     out += "\\n";
                   } else if (c != '\r') {
                     return false;
                   }
                   return true;
                 }), '"');
}

std::string DotHtmlText(std::string_view s) {
  return Map(s, [](char32_t c, std::string& out) {
    if (EscapeMarkup(c, out)) return true;
    if (c != '\n') return false;
    out += "<BR/>";
    return true;
  });
}

std::string MessageText(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  ForEachChar(
      s,
      [&](char32_t c, std::string_view bytes) {
        if (IsControl(c) && c != '\n' && c != '\t') {
          for (char b : bytes) out += fmt::format("\\x{:02x}", static_cast<unsigned char>(b));
        } else {
          out += bytes;
        }
      },
      [&](unsigned char b) { out += fmt::format("\\x{:02x}", b); });
  return out;
}

}  // namespace multibond
