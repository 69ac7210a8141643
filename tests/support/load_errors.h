#pragma once
// Test helper: the diagnostics the loader gives for a model that must fail to load.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "multibond/io/model_loader.h"

namespace multibond::testing {

/// The loader's diagnostics for `yaml` (read as `file`); a test failure if it loads.
inline std::vector<Diagnostic> LoadErrors(const std::string& yaml, const std::string& file = "m.yaml") {
  try {
    (void)LoadModelString(yaml, file);
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  ADD_FAILURE() << "expected a ModelError for:\n" << yaml;
  return {};
}

}  // namespace multibond::testing
