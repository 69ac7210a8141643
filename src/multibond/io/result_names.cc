#include "multibond/io/result_names.h"

#include <algorithm>
#include <array>
#include <string_view>
#include <unordered_set>

#include <fmt/format.h>

#include "multibond/core/utf8.h"

namespace multibond {

namespace {

constexpr size_t kMatlabNameMax = 63;  // MATLAB's namelengthmax

// MATLAB's keywords (iskeyword): not usable as variable names.
constexpr std::array<std::string_view, 20> kMatlabKeywords = {
    "break", "case",   "catch",    "classdef", "continue", "else",   "elseif", "end",   "for",   "function",
    "global", "if",    "otherwise", "parfor",  "persistent", "return", "spmd",  "switch", "try",  "while"};

bool IsAsciiLetter(unsigned char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
bool IsNameChar(unsigned char c) { return IsAsciiLetter(c) || (c >= '0' && c <= '9') || c == '_'; }

bool IsKeyword(std::string_view s) {
  return std::find(kMatlabKeywords.begin(), kMatlabKeywords.end(), s) != kMatlabKeywords.end();
}

/// The length of the UTF-8 character at text[i], or 1 for a byte that does not start one.
size_t CharLength(const std::string& text, size_t i) {
  const auto c = static_cast<unsigned char>(text[i]);
  size_t n = c >= 0xF0 && c <= 0xF4 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 1;
  if (c >= 0xF5) n = 1;
  if (i + n > text.size()) return 1;
  for (size_t k = 1; k < n; ++k)
    if ((static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80) return 1;
  return n;
}

std::string MatlabBase(const std::string& name) {
  std::string s;
  for (size_t i = 0; i < name.size();) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (IsNameChar(c)) {
      s += static_cast<char>(c);
      ++i;
    } else {
      s += '_';
      i += c < 0x80 ? 1 : CharLength(name, i);
    }
  }
  if (s.empty() || !IsAsciiLetter(static_cast<unsigned char>(s[0]))) s.insert(s.begin(), 'x');
  if (s.size() > kMatlabNameMax) s.resize(kMatlabNameMax);
  return s;
}

}  // namespace

bool IsMatlabName(const std::string& name) {
  if (name.empty() || name.size() > kMatlabNameMax || !IsAsciiLetter(static_cast<unsigned char>(name[0]))) return false;
  for (char c : name)
    if (!IsNameChar(static_cast<unsigned char>(c))) return false;
  return !IsKeyword(name);
}

std::vector<std::string> MatlabNames(const std::vector<std::string>& names, const std::vector<std::string>& reserved) {
  std::unordered_set<std::string> taken(reserved.begin(), reserved.end());
  std::vector<std::string> out;
  out.reserve(names.size());
  for (const std::string& name : names) {
    const std::string base = MatlabBase(name);
    std::string candidate = base;
    for (long k = 2; taken.count(candidate) || IsKeyword(candidate); ++k) {
      const std::string suffix = fmt::format("_{}", k);
      candidate = base.substr(0, kMatlabNameMax - suffix.size()) + suffix;
    }
    taken.insert(candidate);
    out.push_back(std::move(candidate));
  }
  return out;
}

std::string Hdf5Name(const std::string& name) {
  if (name.empty()) return "%";
  if (name == ".") return "%2E";
  std::string s;
  s.reserve(name.size());
  for (char c : name) {
    if (c == '%') s += "%25";
    else if (c == '/') s += "%2F";
    else s += c;
  }
  return s;
}

std::string StoredText(const std::string& text) {
  std::string s = EscapeInvalidUtf8(text);
  if (s.find('\0') == std::string::npos) return s;
  std::string out;
  for (char c : s) {
    if (c == '\0') out += "\\x00";
    else out += c;
  }
  return out;
}

}  // namespace multibond
