// multibond check [--suggest [--write FILE]]: causality of every bond, the state variables, and
// the compliant couplings that repair derivative causality.

#include <algorithm>
#include <iostream>
#include <iterator>
#include <memory>

#include <fmt/format.h>

#include "cli.h"
#include "multibond/causality/repair.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/atomic_file.h"
#include "multibond/io/model_repair.h"
#include "multibond/sim/simulator.h"

namespace multibond::cli {

namespace {

namespace fs = std::filesystem;

std::string Stroke(const BondGraph& g, const CausalAssignment& c, int b) {
  const Bond& bond = g.bond(b);
  const int effort_from = c.stroke_at_head[b] ? bond.from : bond.to;
  return fmt::format("effort from {}, flow from {}", Describe(g, effort_from), Describe(g, g.Other(b, effort_from)));
}

struct CheckArgs {
  std::string model;
  LoadArgs load;
  bool suggest = false;
  double frequency = 100.0;     ///< --frequency [Hz]
  double damping_ratio = 0.7;   ///< --damping-ratio
  std::optional<std::string> write;
};

/// " kg m^2" or "" for a domain without units.
std::string Unit(const std::string& u) { return u == "-" ? "" : " " + u; }

std::string Show(const Eigen::MatrixXd& m) {
  const Param p = ParamOf(m);
  if (p.is_scalar) return fmt::format("{:.6g}", p.scalar);
  std::string s = "[";
  const bool diagonal = m.isDiagonal(0.0);
  for (int i = 0; i < m.rows(); ++i) {
    if (i) s += ", ";
    if (diagonal) {
      s += fmt::format("{:.6g}", m(i, i));
      continue;
    }
    s += "[";
    for (int j = 0; j < m.cols(); ++j) s += fmt::format("{}{:.6g}", j ? ", " : "", m(i, j));
    s += "]";
  }
  return s + "]";
}

/// `check --suggest` on a model with ideal constraints (rigid joints and meshes, Sf marked
/// `constraint`): they are solved exactly, not derivative causality; a compliant model gives each
/// of them K and R. Prints them, by mechanism part when there is one.
void PrintRigidParts(const LoadedModel& lm) {
  std::vector<std::string> parts;
  for (const Element& e : lm.graph.elements()) {
    if (e.kind != ElementKind::kSf || !e.constraint) continue;
    std::string part = lm.mechanism ? lm.mechanism->DescribePart(e.name) : "";
    if (part.empty()) part = Describe(lm.graph, lm.graph.Find(e.name));
    if (std::find(parts.begin(), parts.end(), part) == parts.end()) parts.push_back(part);
  }
  if (parts.empty()) return;
  std::cout << fmt::format("\nrigid (ideal constraints, solved exactly by their reactions): {} part{}\n", parts.size(),
                           parts.size() == 1 ? "" : "s");
  for (const auto& p : parts) std::cout << "  - " << p << '\n';
  std::cout << (lm.mechanism ? "  for a compliant model, give these joints and gear meshes K and R instead of 'rigid'\n"
                             : "  for a compliant model, replace each constraint by a C and an R on its junction\n");
}

/// `check --suggest`: the compliant couplings that remove all derivative causality (see
/// causality/repair.h for the method), and with --write the repaired model file. Returns the
/// exit code: 1 (the model as given is not integrally causal) unless the repaired file cannot be
/// written (74).
int Suggest(const LoadedModel& lm, const CheckArgs& a) {
  const CouplingTarget target{a.frequency, a.damping_ratio};
  const RepairResult r = SuggestCouplings(lm.graph, lm.compile.default_domain, target);
  std::cout << fmt::format("\nrepair (--suggest): compliant couplings tuned to f = {:g} Hz{} and zeta = {:g}{}\n", a.frequency,
                           a.frequency == 100.0 ? " (default)" : "", a.damping_ratio, a.damping_ratio == 0.7 ? " (default)" : "");
  std::cout << "  each is a C (K) and an R in parallel on the deflection rate, joined to the bond through a 0-junction;\n"
               "  K = m_eff (2 pi f)^2, R = 2 zeta sqrt(K m_eff), m_eff = I_dep I_ref / (I_dep + I_ref), the reduced inertia\n";
  PrintRigidParts(lm);
  if (lm.mechanism) {
    // A mechanism's bonds are generated: it is repaired in its own terms.
    std::cout << "\nthis is a mechanism file: its bond graph is generated from bodies, joints, gear meshes and drives, so the\n"
                 "coupling belongs in the mechanism, not in the generated graph. Joints, gear meshes and velocity drives are\n"
                 "compliant couplings: connect each part below to what fixes its motion through one of them (with K and R),\n"
                 "or run with --constraints ideal. Stiffness and damping that give the target frequency:\n";
    for (const auto& c : r.couplings) {
      std::string part = lm.mechanism->DescribePart(c.storage);
      if (part.empty()) part = "'" + c.storage + "' (not a mechanism part)";
      const CouplingUnits u = CouplingUnitsOf(c.domain);
      std::cout << fmt::format("  - {} (I '{}'), path {}\n    K = {}{}, R = {}{}; m_eff = {}{} = {}\n", part, c.storage, c.path,
                               Show(c.stiffness), Unit(u.stiffness), Show(c.damping), Unit(u.resistance), Show(c.m_eff),
                               Unit(u.inertia), c.m_eff_note);
    }
    for (const auto& n : r.not_repaired) std::cout << "  - " << n << '\n';
    if (a.write) std::cerr << "error: --write edits plain bond-graph files only; nothing was written\n";
    return kExitModel;
  }
  std::cout << fmt::format("\n{} coupling{}:\n", r.couplings.size(), r.couplings.size() == 1 ? "" : "s");
  int k = 0;
  for (const auto& c : r.couplings) {
    const CouplingUnits u = CouplingUnitsOf(c.domain);
    std::cout << fmt::format("  {}. I '{}' (dependent: {}), on bond '{}' ({} -> {}{}):\n", ++k, c.storage, c.path, c.bond, c.tail, c.head,
                             c.where.known() ? ", " + c.where.ToString() : "");
    std::cout << fmt::format("     {} -> {} -> {}, with 0 '{}' -> 1 '{}' (deflection rate {}.f - {}.f) carrying\n", c.tail, c.zero,
                             c.head, c.zero, c.one, c.tail, c.head);
    std::cout << fmt::format("     C '{}' K = {}{} and R '{}' R = {}{}\n", c.spring, Show(c.stiffness), Unit(u.stiffness), c.damper,
                             Show(c.damping), Unit(u.resistance));
    std::cout << fmt::format("     m_eff = {}{} = {}\n", Show(c.m_eff), Unit(u.inertia), c.m_eff_note);
  }
  for (const auto& n : r.not_repaired) std::cout << "  not repaired: " << n << '\n';
  bool ok = r.integral && !r.couplings.empty();
  if (r.integral) {
    std::cout << "the repaired graph is integrally causal; each coupling removes at least one derivative causality (greedy:\n"
                 "one coupling, then causality again), so none of them is redundant\n";
    try {
      const auto model = CompiledModel::Compile(r.repaired, lm.compile);
      std::cout << fmt::format("it compiles: {} states\n", model->num_states());
    } catch (const ModelError& e) {
      ok = false;
      std::cout << "but it does not compile:\n";
      PrintDiagnostics(e.diagnostics());
    }
  } else {
    std::cout << "the repaired graph is still not integrally causal (see above)\n";
  }
  if (!a.write) return kExitModel;
  if (!ok) {
    std::cerr << "error: no repair that makes the model integrally causal; nothing was written\n";
    return kExitModel;
  }
  RepairedText text;
  try {
    text = RepairModelText(lm.text, lm.file, r, target);
  } catch (const std::runtime_error& e) {
    std::cerr << "error: cannot write the repaired model: " << e.what() << "\n  nothing was written\n";
    return kExitIo;
  }
  const fs::path out(*a.write);
  std::error_code ec;
  if (fs::equivalent(out, lm.file, ec)) {
    std::cerr << fmt::format("error: --write {} would overwrite the model file; give another name\n", out.string());
    return kExitUsage;
  }
  if (out.has_parent_path() && !fs::is_directory(out.parent_path())) {
    std::cerr << fmt::format("error: cannot write '{}': no folder '{}'\n", out.string(), out.parent_path().string());
    return kExitIo;
  }
  WriteFileAtomic(out.string(), text.text);
  std::cout << fmt::format("wrote {} ({} states; 'multibond check {}' accepts it)\n", out.string(), text.states, out.string());
  return kExitModel;
}

int Check(const CheckArgs& a) {
  LoadedModel lm = Load(a.model, a.load);  // not const: its graph is moved into the compiler at the end
  const std::string& path = a.model;
  const BondGraph& g = lm.graph;
  DiagnosticSink sink;
  Structure s;
  CausalAssignment c;
  {
    const InCausalView view(lm.graph);  // the graph as the compiler sees it, for this block
    s = AnalyzeStructure(view.graph(), lm.compile.default_domain, sink);
    sink.ThrowIfErrors();
    c = AssignCausality(view.graph(), s);
  }
  if (lm.mechanism) ExplainInMechanismTerms(*lm.mechanism, c.diagnostics);
  std::cout << fmt::format("model '{}' ({}): {} elements, {} bonds\n\n", g.name(), path, g.num_elements(), g.num_bonds());
  if (!lm.parameters.empty()) {
    std::cout << fmt::format("parameters ({}):\n", lm.parameters.size());
    for (const ModelParameter& q : lm.parameters)
      std::cout << fmt::format("  {} = {:.10g}{}{}{}\n", q.name, q.value, q.unit.empty() || q.unit == "-" ? "" : " " + q.unit,
                               q.is_formula() ? fmt::format("  (= {})", q.text) : "", q.set ? "  (set on the command line)" : "");
    std::cout << '\n';
  }
  std::cout << "causality (the causal stroke is at the element that receives the effort):\n";
  {
    // One line per bond, written at once (a large model has a hundred thousand of them).
    fmt::memory_buffer lines;
    std::string arrow;
    for (int b = 0; b < g.num_bonds(); ++b) {
      const Bond& bond = g.bond(b);
      arrow.clear();
      if (c.stroke_at_head[b]) fmt::format_to(std::back_inserter(arrow), "{} -->| {}", g.element(bond.from).name, g.element(bond.to).name);
      else fmt::format_to(std::back_inserter(arrow), "{} |--> {}", g.element(bond.from).name, g.element(bond.to).name);
      fmt::format_to(std::back_inserter(lines), "  {:<40} [{}]  {}\n", arrow, s.bond_dim[b], Stroke(g, c, b));
    }
    std::cout.write(lines.data(), static_cast<std::streamsize>(lines.size()));
  }
  // With ideal constraints, derivative causality is accepted: the compiler solves the dependent
  // storage exactly. Any other causality problem is still an error.
  bool only_derivative = !c.derivative.empty();
  for (const auto& d : c.diagnostics)
    if (d.severity == Diagnostic::Severity::kError && d.code != codes::kCausalityDerivative) only_derivative = false;
  const bool accepted = lm.compile.ideal_constraints && only_derivative;
  std::string solved;  // said once the model has compiled: it may still refuse them (constraint.unsupported)
  if (accepted) {
    std::vector<Diagnostic> rest;
    for (const auto& d : c.diagnostics)
      if (d.code != codes::kCausalityDerivative) rest.push_back(d);
    PrintDiagnostics(rest);
    std::string names;
    for (int e : c.derivative) names += (names.empty() ? "" : ", ") + Describe(g, e);
    solved = fmt::format("\nideal constraints: {} storage element{} in derivative causality, solved exactly: {}\n",
                         c.derivative.size(), c.derivative.size() == 1 ? "" : "s", names);
  } else {
    PrintDiagnostics(c.diagnostics);
  }
  if (c.has_errors() && !accepted) {
    if (!c.derivative.empty())
      std::cout << fmt::format("\nnot integrally causal: {} storage element{} in derivative causality\n", c.derivative.size(),
                               c.derivative.size() == 1 ? "" : "s");
    else
      std::cout << "\ncausality conflicts: see the errors above\n";
    if (a.suggest && !c.derivative.empty()) return Suggest(lm, a);
    if (a.suggest) std::cout << "--suggest repairs derivative causality only; nothing to propose for these conflicts\n";
    return kExitModel;
  }
  if (a.suggest && accepted) {
    // The model runs with ideal constraints; the couplings are the compliant alternative.
    if (const int code = Suggest(lm, a); code == kExitIo || code == kExitUsage) return code;
  } else if (a.suggest) {
    std::cout << "\n--suggest: nothing to repair (no storage element in derivative causality)" << (a.write ? "; nothing was written" : "") << '\n';
    PrintRigidParts(lm);
  }
  // Also finds algebraic loops. The graph is not read after this: it is moved in, not copied.
  const auto model = CompiledModel::Compile(std::move(lm.graph), lm.compile);
  (void)MakeColumns(*model, false);  // and checks the declared outputs
  std::cout << solved;
  const std::string causal = model->has_constraints()
                                 ? fmt::format("causal with ideal constraints ({} constraint effort{})", model->num_multipliers(), model->num_multipliers() == 1 ? "" : "s")
                                 : "integrally causal";
  std::cout << fmt::format("\n{}; {} states ({} instructions in the plan):\n", causal, model->num_states(), model->num_instructions());
  for (const auto& loop : model->algebraic_loops())
    std::cout << fmt::format("  algebraic loop {}: solved for {} at every evaluation\n", loop.path, loop.torn);
  for (int i = 0; i < model->num_states(); ++i)
    std::cout << fmt::format("  {} [{}]\n", model->state_names()[i], model->state_units()[i]);
  return kExitOk;
}

}  // namespace

Command AddCheckCommand(CLI::App& app) {
  auto a = std::make_shared<CheckArgs>();
  CLI::App* cmd = app.add_subcommand("check", "Assign causality, print it and the state variables; exit 1 unless integrally causal");
  cmd->add_option("MODEL", a->model, "model file (YAML)")->required();
  AddLoadOptions(cmd, a->load);
  cmd->add_flag("--suggest", a->suggest,
                "for derivative causality: list compliant couplings (a C and an R each, greedy: each one needed) that remove "
                "it, with K and R from --frequency and --damping-ratio");
  cmd->add_option("--frequency", a->frequency, "--suggest: target natural frequency of each coupling [Hz] (default 100)")
      ->check(kPositive);
  cmd->add_option("--damping-ratio", a->damping_ratio, "--suggest: target damping ratio of each coupling (default 0.7)")
      ->check(kNonNegative);
  cmd->add_option("--write", a->write, "--suggest: write the repaired model file to FILE (implies --suggest)")
      ->type_name("FILE")
      ->check(kPathName);
  return {cmd,
          [a](const std::vector<std::string>&) {
            a->suggest = a->suggest || a->write.has_value();
            return Check(*a);
          },
          [a] { return a->write.has_value(); }};
}

}  // namespace multibond::cli
