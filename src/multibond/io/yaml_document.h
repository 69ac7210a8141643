#pragma once
/// \file
/// The first section of loading: a model file's bytes to the YAML mapping the other sections read.
/// The file is read within its limits (a regular file of at most InputLimits::file_bytes), its
/// text must be UTF-8, the YAML within InputLimits::yaml_nodes and ::depth (yaml_bounds.h), one
/// document, a mapping, without duplicate or merge keys; a syntax error is explained where its
/// cause can be told from the text.

#include <cstdint>
#include <string>
#include <unordered_set>

#include "multibond/io/yaml_values.h"

namespace multibond {

/// The text of the model file `path`. Throws ModelError: "io.not_regular" for a directory, device,
/// FIFO or socket, "io.unreadable" for a file that cannot be opened or read, "limit.file-size"
/// for one longer than limits.file_bytes (no more than that is read).
std::string ReadModelText(const std::string& path, const InputLimits& limits);

class YamlDocument : public ValueReader {
 public:
  using ValueReader::ValueReader;

  /// The context's text as a YAML mapping; every problem above is thrown as a ModelError.
  YAML::Node Parse();

 private:
  /// A yaml.syntax diagnostic for `e`, at the cause when the text tells it.
  Diagnostic ExplainSyntaxError(const YAML::Exception& e) const;
  /// Whether the '{' or '[' at text_[i] opens a flow collection.
  bool OpensFlow(size_t i) const;
  /// Reports every key given twice in one mapping, and every merge key, below `node`. Each
  /// collection of the text is walked once, however many aliases name it (a billion laughs is
  /// then as long to check as its text), and a stop asked for ends the walk (Interrupted).
  void CheckDuplicateKeys(const YAML::Node& node, const std::string& path, bool element_names = false);

  const std::string& text_ = cx_.text;
  std::unordered_set<std::int64_t> walked_;  ///< collections checked: 2 x their offset in the text (+1 under elements)
  std::uint64_t visits_ = 0;
};

}  // namespace multibond
