// multibond equations: the state equations generated from the graph, with their causal paths.

#include <iostream>
#include <memory>

#include "cli.h"
#include "multibond/compile/equations.h"

namespace multibond::cli {

namespace {

struct EquationsArgs {
  std::string model, format = "text";
  LoadArgs load;
};

int Equations(const EquationsArgs& a) {
  const LoadedModel lm = Load(a.model, a.load);
  const auto model = CompiledModel::Compile(lm.graph, lm.compile);
  std::cout << FormatEquations(*model, a.format == "latex" ? EquationFormat::kLatex : EquationFormat::kText);
  return kExitOk;
}

}  // namespace

Command AddEquationsCommand(CLI::App& app) {
  auto a = std::make_shared<EquationsArgs>();
  CLI::App* cmd = app.add_subcommand("equations", "Print the state equations generated from the graph, with their causal paths");
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  cmd->add_option("--format", a->format, "text or latex")->check(CLI::IsMember({"text", "latex"}));
  AddLoadOptions(cmd, a->load);
  return {cmd, [a](const std::vector<std::string>&) { return Equations(*a); }};
}

}  // namespace multibond::cli
