#pragma once
/// \file
/// Suggestions for a misspelt word.

#include <string>
#include <vector>

namespace multibond {

/// The closest of `candidates` to `word` (edit distance <= 2 or a prefix), or "".
std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace multibond
