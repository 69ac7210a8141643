#pragma once
/// \file
/// Suggestions for a misspelt word.

#include <string>
#include <vector>

namespace multibond {

/// The closest of `candidates` to `word` (edit distance <= 2 or a prefix), or "".
std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates);
/// The same for names in formulas, which are often one or two letters: a candidate that has no
/// letter in common with `word` ('k' for 'a') is no suggestion.
std::string DidYouMeanName(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace multibond
