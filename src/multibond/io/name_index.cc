#include "multibond/io/name_index.h"

namespace multibond {

const SourceLocation* NameIndex::Add(const std::string& name, const SourceLocation& where) {
  const auto [it, fresh] = index_.emplace(name, names_.size());
  if (!fresh) return &where_[it->second];
  names_.push_back(name);
  where_.push_back(where);
  return nullptr;
}

const SourceLocation* NameIndex::Find(const std::string& name) const {
  const auto it = index_.find(name);
  return it == index_.end() ? nullptr : &where_[it->second];
}

}  // namespace multibond
