#pragma once
// Test helpers: a model's text with a piece of it replaced (a test failure if the piece is not
// there, so that an edit of the text cannot silently leave a test running the original).

#include <string>

#include <gtest/gtest.h>

namespace multibond::testing {

/// `text` with the first `from` replaced by `to`.
inline std::string Replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// `text` with every `from` replaced by `to`.
inline std::string ReplacedAll(std::string text, const std::string& from, const std::string& to) {
  int n = 0;
  for (auto at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()), ++n) text.replace(at, from.size(), to);
  EXPECT_GT(n, 0) << from;
  return text;
}

}  // namespace multibond::testing
