#pragma once
// Test helper: the message of the error a call throws.

#include <stdexcept>
#include <string>

namespace multibond::testing {

/// The message of the std::runtime_error that `f` throws ("" if it throws none).
template <class F>
std::string RuntimeErrorOf(F&& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

}  // namespace multibond::testing
