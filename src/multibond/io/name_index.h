#pragma once
/// \file
/// Names a model file defines, each with the place it is first defined: found in O(1) (a hash
/// map), listed in the order of definition (for did-you-mean suggestions, which must not depend on
/// a hash order).

#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "multibond/core/error.h"

namespace multibond {

class NameIndex {
 public:
  /// Adds `name`, defined at `where`. Returns nullptr, or the place of the first definition if the
  /// name is already there (which is kept).
  const SourceLocation* Add(const std::string& name, const SourceLocation& where);
  /// The place where `name` is defined, or nullptr.
  const SourceLocation* Find(const std::string& name) const;
  bool contains(const std::string& name) const { return index_.count(name) > 0; }
  /// The names in the order they were first added.
  const std::vector<std::string>& names() const { return names_; }
  std::size_t size() const { return names_.size(); }

 private:
  std::unordered_map<std::string, std::size_t> index_;  ///< name -> its position in names_
  std::vector<std::string> names_;
  std::vector<SourceLocation> where_;
};

}  // namespace multibond
