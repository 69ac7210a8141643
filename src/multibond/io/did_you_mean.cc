#include "multibond/io/did_you_mean.h"

#include <algorithm>
#include <cctype>

namespace multibond {

namespace {

int EditDistance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (std::tolower(a[i - 1]) == std::tolower(b[j - 1]) ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

}  // namespace

std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  int best_d = 3;
  for (const auto& c : candidates) {
    const int d = EditDistance(word, c);
    if (d < best_d || (d == best_d && best.empty() && !word.empty() && c.rfind(word, 0) == 0)) {
      best_d = d;
      best = c;
    }
  }
  if (best.empty())
    for (const auto& c : candidates)
      if (word.size() >= 3 && c.rfind(word, 0) == 0) return c;
  return best_d <= std::max<int>(1, static_cast<int>(word.size()) / 3) || best_d <= 2 ? best : "";
}

std::string DidYouMeanName(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string guess = DidYouMean(word, candidates);
  for (const char c : guess)
    for (const char w : word)
      if (std::tolower(static_cast<unsigned char>(c)) == std::tolower(static_cast<unsigned char>(w))) return guess;
  return "";
}

}  // namespace multibond
