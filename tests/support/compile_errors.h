#pragma once
// Test helpers: the diagnostics the compiler gives for a model that loads and must not compile.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/model_loader.h"

namespace multibond::testing {

/// The compiler's diagnostics for `yaml` (read as "<test>", which must load); a test failure if it
/// compiles.
inline std::vector<Diagnostic> CompileErrors(const std::string& yaml) {
  const LoadedModel lm = LoadModelString(yaml, "<test>");
  try {
    (void)CompiledModel::Compile(lm.graph, lm.compile);
  } catch (const ModelError& e) {
    return e.diagnostics();
  }
  ADD_FAILURE() << "expected the compiler to refuse:\n" << yaml;
  return {};
}

/// A diagnostic's detail lines, each ended by a newline.
inline std::string DetailsOf(const Diagnostic& d) {
  std::string details;
  for (const std::string& line : d.details) details += line + "\n";
  return details;
}

}  // namespace multibond::testing
