#pragma once
// Test helper: the header of a corpus file, its leading comment lines "# key: value", in order
// (the bad-model, hostile and fuzz corpora say what is expected of them this way).

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace multibond::testing {

inline std::string TrimSpace(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r"), z = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, z - a + 1);
}

/// Every "# key: value" line at the top of `file` (lines without a colon are skipped; the header
/// ends at the first line that is not a comment).
inline std::vector<std::pair<std::string, std::string>> ReadCorpusHeader(const std::filesystem::path& file) {
  std::vector<std::pair<std::string, std::string>> fields;
  std::ifstream in(file, std::ios::binary);
  std::string line;
  while (std::getline(in, line) && line.rfind('#', 0) == 0) {
    const std::string body = TrimSpace(line.substr(1));
    const auto colon = body.find(':');
    if (colon != std::string::npos) fields.emplace_back(body.substr(0, colon), TrimSpace(body.substr(colon + 1)));
  }
  return fields;
}

}  // namespace multibond::testing
