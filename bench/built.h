#pragma once
// The benchmarks' compiled model and, when asked for, its generated code (compile/
// generated_rhs.h), loaded before the benchmark starts: as the CLI runs a model whose code is in
// the JIT cache.

#include <memory>
#include <string>

#include "multibond/compile/compiled_model.h"
#include "multibond/compile/generated_rhs.h"

namespace multibond::bench {

struct Built {
  std::shared_ptr<const CompiledModel> model;
  std::shared_ptr<const GeneratedRhs> code;
  /// A workspace that the generated code evaluates into (the interpreter without code).
  Workspace MakeWorkspace() const { return model->MakeWorkspace(code.get()); }
  bool generated() const { return code && code->ready(); }
  std::string engine() const { return RhsEngine(code.get()); }
};

inline Built Build(const BondGraph& graph, const CompileOptions& options, bool generate) {
  Built b{CompiledModel::Compile(graph, options), nullptr};
  if (generate) b.code = GeneratedRhs::Start(b.model);
  return b;
}

}  // namespace multibond::bench
