// multibond: the command-line front end. It parses arguments, calls the library and maps its
// three error channels to exit codes: 0 ok, 1 model error, 2 solver error, 64 usage,
// 74 output cannot be written, 130 interrupted.

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <tuple>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "multibond/compile/equations.h"
#include "multibond/core/interrupt.h"
#include "multibond/causality/repair.h"
#include "multibond/io/dot_writer.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"
#include "multibond/io/model_repair.h"
#include "multibond/io/output_folder.h"
#include "multibond/io/plots.h"
#include "multibond/io/results_writer.h"
#include "multibond/sim/compare.h"
#include "multibond/version.h"

namespace mb = multibond;
namespace fs = std::filesystem;

namespace {

constexpr int kExitOk = 0, kExitModel = 1, kExitSolver = 2, kExitUsage = 64, kExitIo = 74;

/// Leaves a command with an exit code and a message (printed as "error: <message>").
struct CliExit {
  int code;
  std::string message;
};

/// CLI11's own range checks name the range ("Value 0 not in range 0.000000 to 1797...") and say
/// the same for a word that is not a number; these say what is expected and what was given.
CLI::Validator NumberAbove(double low, bool inclusive) {
  return CLI::Validator(
      [low, inclusive](std::string& text) -> std::string {
        double v = 0.0;
        try {
          size_t used = 0;
          v = std::stod(text, &used);
          if (used != text.size()) throw std::invalid_argument(text);
        } catch (const std::out_of_range&) {
          return fmt::format("'{}' is beyond the range of normal double-precision numbers (2.2e-308 to 1.8e308 in magnitude)", text);
        } catch (const std::exception&) {
          return fmt::format("'{}' is not a number", text);
        }
        if (!std::isfinite(v)) return fmt::format("must be a finite number (got {})", text);
        if (inclusive ? !(v >= low) : !(v > low)) return fmt::format("must be {} {:g} (got {})", inclusive ? ">=" : ">", low, text);
        return "";
      },
      inclusive ? "NUMBER >= 0" : "NUMBER > 0");
}
const CLI::Validator kPositive = NumberAbove(0.0, false), kNonNegative = NumberAbove(0.0, true);

/// An output path: "" names nothing (a usage error, 64, not a failed write, 74).
const CLI::Validator kPathName(
    [](std::string& text) -> std::string { return text.empty() ? "must name a file or folder (got an empty string)" : ""; },
    "PATH");

/// What to try after a failed run, from what failed and with which settings (the same advice
/// for every failure sent users of rk4 to --rtol, which it ignores, and users of bdf to bdf).
std::string FailureHint(const mb::RunOptions& o, const std::string& message) {
  const mb::IntegratorOptions& i = o.integrator;
  const auto has = [&](const char* text) { return message.find(text) != std::string::npos; };
  if (has("evaluating the outputs failed")) return "check the model's parameters (an output could not be evaluated there)";
  if (has("derivatives of the initial state are not finite"))
    return "check the parameters and initial values of those states' elements (no solver or tolerance can help)";
  if (has("beyond machine precision")) return "loosen the tolerances (--rtol, --atol): double precision cannot resolve them";
  if (i.fixed_step > 0)
    return fmt::format("try a smaller fixed step (--step, now {:g} s): beyond its stability limit a fixed step blows up; or an adaptive "
                       "solver (--solver srk3, bs3, dopri5 or bdf without --step)", i.fixed_step);
  if (has("max_steps_per_output")) {
    // Too many steps in one output interval: a shorter interval lets them be taken; what else
    // helps depends on what held the steps short.
    std::string hint = fmt::format("a shorter output interval (--dt, now {:g} s) lets the solver take more steps", o.dt);
    if (i.max_step > 0) hint += fmt::format("; or a larger --max-step (now {:g} s)", i.max_step);
    if (!mb::UsesNewtonMatrix(i.method)) hint += "; or, if the model is stiff, --solver bdf";
    return hint + "; or looser tolerances (--rtol, --atol), if the accuracy allows";
  }
  if (i.method == mb::Method::kBdf) return "try a tighter tolerance (--rtol), or check the model's parameters (is the solution blowing up?)";
  return "try a stiff solver (--solver bdf), a tighter tolerance (--rtol), or check the model's parameters";
}


void PrintDiagnostics(const std::vector<mb::Diagnostic>& ds) {
  for (const auto& d : ds) std::cerr << d.ToString() << '\n';
}

int ModelFailure(const mb::ModelError& e, bool wrote_nothing) {
  PrintDiagnostics(e.diagnostics());
  int errors = 0;
  bool unreadable = false;  // a model file that cannot be read is an I/O failure (74), not a model error
  for (const auto& d : e.diagnostics()) {
    errors += d.severity == mb::Diagnostic::Severity::kError;
    unreadable = unreadable || d.code.rfind("io.", 0) == 0;
  }
  if (unreadable) {
    if (wrote_nothing) std::cerr << "nothing was written\n";
    return kExitIo;
  }
  std::cerr << fmt::format("{} error{} in the model{}\n", errors, errors == 1 ? "" : "s", wrote_nothing ? "; nothing was written" : "");
  return kExitModel;
}

/// 128 + the signal that stopped the command (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP).
int InterruptedExitCode() { return 128 + (mb::StopSignal() ? mb::StopSignal() : SIGINT); }

/// The command line as one line of text (the lock file names the command that holds a folder).
std::string CommandLine(const std::vector<std::string>& argv) {
  std::string s;
  for (const std::string& a : argv) s += (s.empty() ? "" : " ") + a;
  return s;
}

/// Refuses (exit 64) an output that is one of the command's input files, e.g. compare -o B.yaml,
/// which would replace the model by the report.
void RefuseWritingOnto(const std::vector<fs::path>& outputs, const std::vector<std::string>& inputs) {
  for (const fs::path& out : outputs)
    for (const std::string& in : inputs) {
      std::error_code ec;
      if (fs::equivalent(out, in, ec))
        throw CliExit{kExitUsage, fmt::format("'{}' is '{}', an input of this command: writing there would replace it; choose "
                                              "another output name", out.string(), in)};
    }
}

std::string Stroke(const mb::BondGraph& g, const mb::CausalAssignment& c, int b) {
  const mb::Bond& bond = g.bond(b);
  const int effort_from = c.stroke_at_head[b] ? bond.from : bond.to;
  return fmt::format("effort from {}, flow from {}", mb::Describe(g, effort_from), mb::Describe(g, g.Other(b, effort_from)));
}

/// Loads a model; `constraints` ("ideal" or "compliant", from --constraints) overrides the file's
/// `constraints:` setting, `loops` ("solve" or "error", from --algebraic-loops) its
/// `algebraic_loops:`.
mb::LoadedModel Load(const std::string& path, const std::optional<std::string>& constraints = std::nullopt,
                     const std::optional<std::string>& loops = std::nullopt) {
  mb::LoadedModel lm = mb::LoadModelFile(path);
  PrintDiagnostics(lm.warnings);
  if (constraints) lm.compile.ideal_constraints = *constraints == "ideal";
  if (loops) lm.compile.solve_algebraic_loops = *loops == "solve";
  return lm;
}

/// --limit NAME=VALUE (repeatable): raises or lowers a bound on the input (io/limits.h).
void AddLimitOption(CLI::App* cmd, std::vector<std::string>& limits) {
  std::string names;
  for (const std::string& n : mb::LimitNames()) names += (names.empty() ? "" : ", ") + n;
  cmd->add_option("--limit", limits,
                  "NAME=VALUE: change a bound on the input (repeatable; VALUE a whole number, k/M/G suffixes allowed); "
                  "names: " + names + " (docs/security.md)")
      ->type_name("NAME=VALUE")
      ->take_all();
}

/// The limits given with --limit over the defaults; a bad one is a usage error.
mb::InputLimits ParseLimits(const std::vector<std::string>& assignments) {
  mb::InputLimits limits;
  for (const std::string& a : assignments) {
    try {
      mb::SetLimit(limits, a);
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, e.what()};
    }
  }
  return limits;
}

void AddConstraintsOption(CLI::App* cmd, std::optional<std::string>& constraints) {
  cmd->add_option("--constraints", constraints,
                  "ideal: accept derivative causality and solve the dependent storage exactly (constraint efforts); "
                  "compliant: require integral causality (default: the model file's 'constraints:', else compliant)")
      ->check(CLI::IsMember({"ideal", "compliant"}));
}

void AddLoopsOption(CLI::App* cmd, std::optional<std::string>& loops) {
  cmd->add_option("--algebraic-loops", loops,
                  "solve: tear each algebraic loop at one variable and solve its linear system at every evaluation; "
                  "error: report it and refuse the model (default: the model file's 'algebraic_loops:', else error)")
      ->check(CLI::IsMember({"solve", "error"}));
}

// ---------------------------------------------------------------------------------------------
// check [--suggest]

struct CheckArgs {
  std::string model;
  std::optional<std::string> constraints, loops;
  bool suggest = false;
  double frequency = 100.0;     ///< --frequency [Hz]
  double damping_ratio = 0.7;   ///< --damping-ratio
  std::optional<std::string> write;
};

/// " kg m^2" or "" for a domain without units.
std::string Unit(const std::string& u) { return u == "-" ? "" : " " + u; }

std::string Show(const Eigen::MatrixXd& m) {
  const mb::Param p = mb::ParamOf(m);
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
void PrintRigidParts(const mb::LoadedModel& lm) {
  std::vector<std::string> parts;
  for (const mb::Element& e : lm.graph.elements()) {
    if (e.kind != mb::ElementKind::kSf || !e.constraint) continue;
    std::string part = lm.mechanism ? lm.mechanism->DescribePart(e.name) : "";
    if (part.empty()) part = mb::Describe(lm.graph, lm.graph.Find(e.name));
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
int Suggest(const mb::LoadedModel& lm, const CheckArgs& a) {
  const mb::CouplingTarget target{a.frequency, a.damping_ratio};
  const mb::RepairResult r = mb::SuggestCouplings(lm.graph, lm.compile.default_domain, target);
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
      const mb::CouplingUnits u = mb::CouplingUnitsOf(c.domain);
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
    const mb::CouplingUnits u = mb::CouplingUnitsOf(c.domain);
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
      mb::CompileOptions co = lm.compile;
      co.generate_code = false;
      const auto model = mb::CompiledModel::Compile(r.repaired, co);
      std::cout << fmt::format("it compiles: {} states\n", model->num_states());
    } catch (const mb::ModelError& e) {
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
  mb::RepairedText text;
  try {
    text = mb::RepairModelText(lm.text, lm.file, r, target);
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
  mb::WriteFileAtomic(out.string(), text.text);
  std::cout << fmt::format("wrote {} ({} states; 'multibond check {}' accepts it)\n", out.string(), text.states, out.string());
  return kExitModel;
}

int Check(const CheckArgs& a) {
  const mb::LoadedModel lm = Load(a.model, a.constraints, a.loops);
  const std::string& path = a.model;
  const mb::BondGraph& g = lm.graph;
  mb::DiagnosticSink sink;
  const mb::BondGraph view = mb::CausalView(g);
  const mb::Structure s = mb::AnalyzeStructure(view, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  mb::CausalAssignment c = mb::AssignCausality(view, s);
  if (lm.mechanism) mb::ExplainInMechanismTerms(*lm.mechanism, c.diagnostics);
  std::cout << fmt::format("model '{}' ({}): {} elements, {} bonds\n\n", g.name(), path, g.num_elements(), g.num_bonds());
  std::cout << "causality (the causal stroke is at the element that receives the effort):\n";
  for (int b = 0; b < g.num_bonds(); ++b) {
    const mb::Bond& bond = g.bond(b);
    const std::string arrow = c.stroke_at_head[b] ? fmt::format("{} -->| {}", g.element(bond.from).name, g.element(bond.to).name)
                                                  : fmt::format("{} |--> {}", g.element(bond.from).name, g.element(bond.to).name);
    std::cout << fmt::format("  {:<40} [{}]  {}\n", arrow, s.bond_dim[b], Stroke(g, c, b));
  }
  // With ideal constraints, derivative causality is accepted: the compiler solves the dependent
  // storage exactly. Any other causality problem is still an error.
  bool only_derivative = !c.derivative.empty();
  for (const auto& d : c.diagnostics)
    if (d.severity == mb::Diagnostic::Severity::kError && d.code != "causality.derivative") only_derivative = false;
  const bool accepted = lm.compile.ideal_constraints && only_derivative;
  if (accepted) {
    std::vector<mb::Diagnostic> rest;
    for (const auto& d : c.diagnostics)
      if (d.code != "causality.derivative") rest.push_back(d);
    PrintDiagnostics(rest);
    std::string names;
    for (int e : c.derivative) names += (names.empty() ? "" : ", ") + mb::Describe(g, e);
    std::cout << fmt::format("\nideal constraints: {} storage element{} in derivative causality, solved exactly: {}\n",
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
  const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);  // also finds algebraic loops
  (void)mb::MakeColumns(*model, false);  // and checks the declared outputs
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

int Equations(const std::string& path, const std::string& format, const std::optional<std::string>& constraints,
              const std::optional<std::string>& loops) {
  const mb::LoadedModel lm = Load(path, constraints, loops);
  const auto model = mb::CompiledModel::Compile(lm.graph, lm.compile);
  std::cout << mb::FormatEquations(*model, format == "latex" ? mb::EquationFormat::kLatex : mb::EquationFormat::kText);
  return kExitOk;
}

int Graph(const std::string& path, const std::string& out) {
  const mb::LoadedModel lm = Load(path);
  mb::DiagnosticSink sink;
  const mb::BondGraph view = mb::CausalView(lm.graph);
  const mb::Structure s = mb::AnalyzeStructure(view, lm.compile.default_domain, sink);
  sink.ThrowIfErrors();
  const mb::CausalAssignment c = mb::AssignCausality(view, s);
  const std::string dot = mb::MakeDot(lm.graph, &s, &c, mb::LinkGrouping(lm));
  const fs::path outp(out);
  std::string ext = outp.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  if (outp.stem().empty() || (ext != ".dot" && ext != ".gv" && ext != ".svg" && ext != ".png"))
    throw CliExit{kExitUsage, fmt::format("the drawing's file name must end in .dot, .gv, .svg or .png (got '{}')", out)};
  const fs::path dot_path = ext == ".dot" || ext == ".gv" ? outp : fs::path(outp).replace_extension(".dot");
  RefuseWritingOnto({dot_path, outp}, {path});
  if (dot_path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(dot_path.parent_path(), ec);
    if (ec)  // e.g. a path through a file: afile/g.dot
      throw CliExit{kExitIo, fmt::format("cannot write '{}': cannot create the folder '{}' ({})", out,
                                         dot_path.parent_path().string(), ec.message())};
  }
  mb::WriteFileAtomic(dot_path.string(), dot);
  std::cout << "wrote " << dot_path.string() << '\n';
  const std::vector<std::string> formats = ext == ".png" ? std::vector<std::string>{"png"} : std::vector<std::string>{"svg"};
  for (const auto& f : formats) {
    // The picture keeps the name asked for (h.SVG stays h.SVG); a .dot/.gv request gets an .svg beside it.
    const fs::path img = ext == ".dot" || ext == ".gv" ? fs::path(dot_path).replace_extension("." + f) : outp;
    std::string err;
    if (mb::RenderWithGraphviz(dot_path.string(), img.string(), f, &err)) std::cout << "wrote " << img.string() << '\n';
    else std::cerr << "note: " << err << " (the DOT file is there; install graphviz to render it)\n";
  }
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------
// The run options shared by `run` and `compare`.

struct RunArgs {
  std::optional<double> t_end, dt, rtol, atol, step, max_step;
  std::optional<std::string> solver, constraints, loops, coordinates;
  bool all_variables = false, no_projection = false;
  std::string jit = "auto";
  std::string jacobian = "auto";
  std::vector<std::string> limits;
};

void AddRunOptions(CLI::App* cmd, RunArgs& a) {
  cmd->add_option("--t-end", a.t_end, "end time [s] (default: the model's, else 1)")->check(kPositive);
  cmd->add_option("--dt", a.dt, "output interval [s] (default: the model's, else 1e-3)")->check(kPositive);
  cmd->add_option("--solver", a.solver, "bdf, adams, dopri5, bs3 (Bogacki-Shampine 3(2)), srk3 (stabilised RK 3(2), for stiff explicit runs) or rk4 (default: the model's, else bdf)");
  cmd->add_option("--rtol", a.rtol, "relative tolerance (default: the model's, else 1e-8)")->check(kPositive);
  cmd->add_option("--atol", a.atol, "absolute tolerance (default: the model's, else 1e-10)")->check(kPositive);
  cmd->add_option("--step", a.step, fmt::format("fixed step [s] for {} (required for rk4)", mb::kFixedStepMethodNames))->check(kPositive);
  cmd->add_option("--max-step", a.max_step, "largest step [s] of the adaptive methods")->check(kPositive);
  cmd->add_flag("--all-variables", a.all_variables, "add a column for every effort and flow");
  cmd->add_option("--jit", a.jit,
                  "right-hand side as generated C++ compiled with the system compiler (auto: when one works; "
                  "off: the plan interpreter)")
      ->check(CLI::IsMember({"auto", "on", "off"}));
  cmd->add_flag("--no-projection", a.no_projection,
                "do not re-orthonormalise orientation matrices after each step (shows the raw drift)");
  cmd->add_option("--jacobian", a.jacobian,
                  "bdf and adams: the Newton matrix (sparse: difference quotients on the model's structural pattern, one "
                  "evaluation per group of columns sharing no row, KLU; dense: one evaluation per state, dense LU; auto: "
                  "sparse from 50 states when at most a quarter of the Jacobian can be nonzero)")
      ->check(CLI::IsMember({"auto", "dense", "sparse"}));
  cmd->add_option("--coordinates", a.coordinates,
                  "joint: integrate a mechanism's motion relative to its joints (each body's angle in its bearing and "
                  "its rate; steady rotation does not bound the step), inertial: the model's own states (default: the "
                  "model's 'coordinates:', else inertial); the output columns are the same")
      ->check(CLI::IsMember({"joint", "inertial"}));
  AddConstraintsOption(cmd, a.constraints);
  AddLoopsOption(cmd, a.loops);
  AddLimitOption(cmd, a.limits);
}

/// A model loaded and compiled, with its run options resolved: the command line over the model
/// file's `simulation:` section over the built-in defaults.
struct PreparedRun {
  mb::LoadedModel lm;
  std::shared_ptr<const mb::CompiledModel> model;
  mb::RunOptions options;
  std::string solver;
  std::string coordinates;  ///< "joint" or "inertial"
};

/// Throws ModelError (bad model, bad output), CliExit 64 (unknown solver) or 74 (--jit on
/// without a working compiler).
PreparedRun PrepareRun(const std::string& path, const RunArgs& a) {
  PreparedRun p{Load(path, a.constraints, a.loops), nullptr, {}, {}};
  mb::CompileOptions co = p.lm.compile;
  co.generate_code = a.jit != "off";
  p.model = mb::CompiledModel::Compile(p.lm.graph, co);
  // --jit on for a model that generated code does not cover is a usage error; a compiler that fails is the machine's.
  if (a.jit == "on" && !p.model->uses_generated_code())
    throw CliExit{p.model->algebraic_loops().empty() ? kExitIo : kExitUsage, "--jit on, but " + p.model->rhs_engine()};
  // --jit auto falls back to the interpreter when the compiler fails: same numbers, slower; said
  // here, not only in run.json.
  if (a.jit == "auto" && !p.model->uses_generated_code() && p.model->rhs_engine().find("code generation") != std::string::npos)
    std::cerr << "warning: running on the interpreter: " << p.model->rhs_engine() << '\n';
  const mb::SimulationDefaults& d = p.lm.simulation;
  mb::RunOptions& o = p.options;
  o.t_end = a.t_end.value_or(d.t_end.value_or(1.0));
  o.dt = a.dt.value_or(d.dt.value_or(1e-3));
  p.solver = a.solver.value_or(d.solver.value_or("bdf"));
  try {
    o.integrator.method = mb::ParseMethod(p.solver);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  o.integrator.rtol = a.rtol.value_or(d.rtol.value_or(1e-8));
  o.integrator.atol = a.atol.value_or(d.atol.value_or(1e-10));
  o.integrator.fixed_step = a.step.value_or(d.step.value_or(0.0));
  // The file's fixed step belongs to the file's solver: a step-choosing solver asked for on the
  // command line leaves it (only a --step given with it is refused).
  if (!a.step && a.solver && mb::UsesNewtonMatrix(o.integrator.method))
    o.integrator.fixed_step = 0.0;
  o.integrator.max_step = a.max_step.value_or(d.max_step.value_or(0.0));
  o.all_variables = a.all_variables;
  p.coordinates = a.coordinates.value_or(d.coordinates.value_or("inertial"));
  if (p.coordinates == "joint") {
    if (!p.lm.mechanism || p.lm.mechanism->empty())
      throw CliExit{kExitUsage, "--coordinates joint is for mechanisms: the model has no bodies"};
    o.joint_coordinates = p.lm.mechanism->MakeJointTree();
  }
  o.integrator.project = !a.no_projection;
  o.max_forced_steps = static_cast<double>(ParseLimits(a.limits).steps);
  o.integrator.jacobian = mb::ParseJacobianKind(a.jacobian);
  // An explicit method forms no Newton matrix: a --jacobian for it is recorded but changes nothing.
  if (a.jacobian != "auto" && !mb::UsesNewtonMatrix(o.integrator.method))
    std::cerr << fmt::format("warning: --jacobian {} has no effect with the explicit solver '{}' (only bdf and adams form a "
                             "Newton matrix)\n", a.jacobian, p.solver);
  o.stop = &mb::StopFlag();
  (void)mb::MakeColumns(*p.model, o.all_variables);  // a bad output is a model error: before any file is touched
  try {
    mb::CheckRunOptions(*p.model, o);  // and so are options the run would refuse
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  return p;
}

struct RunCommand {
  RunArgs run;
  std::string model, out;
  bool quiet = false;
};

int Run(const RunCommand& a, const std::vector<std::string>& argv) {
  PreparedRun p = PrepareRun(a.model, a.run);
  const mb::LoadedModel& lm = p.lm;
  const auto& model = p.model;
  mb::RunOptions& o = p.options;
  const bool tty = isatty(fileno(stderr)) && !a.quiet;
  if (tty) o.progress = [&](double f) { std::fprintf(stderr, "\r  t = %-10.4g s  %3.0f%%", o.t_start + f * (o.t_end - o.t_start), 100 * f); };

  // The model compiled: only now is the output folder touched.
  mb::ThrowIfStopRequested("loading and compiling the model");
  RefuseWritingOnto({fs::path(a.out) / "results.csv", fs::path(a.out) / "run.json"}, {a.model});
  const mb::OutputFolder folder(a.out, CommandLine(argv));
  for (const std::string& stale : folder.removed_stale())
    std::cerr << fmt::format("note: removed '{}', a temporary file of an earlier command that did not finish\n", folder.File(stale));
  mb::CsvWriter csv(folder.File("results.csv"), /*publish=*/false);
  mb::AtomicFile run_json(folder.File("run.json"));  // a name it cannot take is said before the run
  mb::RunSummary summary;
  try {
    summary = mb::Simulate(*model, o, csv);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitUsage;
  }
  if (tty) std::fprintf(stderr, "\n");
  nlohmann::json record = mb::MakeRunRecord(a.model, lm.text, lm.graph.name(), o, summary, argv);
  record["rhs_engine"] = model->rhs_engine();
  record["options"]["jit"] = a.run.jit;
  record["options"]["coordinates"] = p.coordinates;
  record["options"]["ideal_constraints"] = lm.compile.ideal_constraints;  // derivative causality solved by constraints
  record["options"]["algebraic_loops"] = lm.compile.solve_algebraic_loops ? "solve" : "error";
  // What the compiled model has, whichever way (rigid parts, Sf constraints, cut inertias).
  record["constraint_efforts"] = model->num_multipliers();
  record["algebraic_loops_solved"] = model->algebraic_loops().size();
  // Published together, run.json last: it records the size and hash of the results.csv it goes
  // with, and a results.csv without a run.json beside it is from a command that did not finish.
  record["results"] = mb::DataFileRecord("results.csv", csv.bytes(), csv.sha256());
  run_json.Write(mb::DumpRecord(record));
  run_json.Finish();  // a full disk shows here, before anything is published
  std::error_code ignored;
  fs::remove(folder.File("run.json"), ignored);  // an earlier run's record never describes these results
  csv.Publish();
  run_json.Publish();
  if (!a.quiet || summary.status != mb::RunStatus::kOk) {
    std::cout << fmt::format("{}: {} to t = {:g} s with {} ({} steps, {} right-hand sides, {:.3f} s wall)\n",
                             lm.graph.name(), mb::RunStatusName(summary.status), summary.t_reached, p.solver, summary.stats.steps,
                             summary.stats.rhs_evals, summary.wall_seconds);
    if (model->has_energy_account())
      std::cout << fmt::format("energy: work {:.9g} J, stored {:.9g} J, dissipated {:.9g} J, residual {:.3g}\n", summary.energy_work,
                               summary.energy_stored, summary.energy_dissipated, summary.energy_residual);
    std::cout << fmt::format("wrote {}/results.csv and {}/run.json\n", a.out, a.out);
  }
  for (const std::string& w : summary.warnings) std::cerr << "warning: " << w << '\n';  // also in run.json
  if (summary.status == mb::RunStatus::kFailed) {
    std::cerr << "error: the simulation failed " << summary.message << "\n  the results up to then are kept; run.json marks the run as failed\n"
              << "  hint: " << FailureHint(o, summary.message) << '\n';
    return kExitSolver;
  }
  if (summary.status == mb::RunStatus::kInterrupted) {
    std::cerr << summary.message << "; the results up to then are kept\n";
    return InterruptedExitCode();
  }
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------
// compare A B

struct CompareCommand {
  RunArgs run;
  std::string a, b, out;
  std::string sort = "diff";
  std::optional<int> top;
};

std::string RunSettings(const PreparedRun& p) {
  const mb::IntegratorOptions& i = p.options.integrator;
  std::string s = fmt::format("solver {}, rtol {:g}, atol {:g}", p.solver, i.rtol, i.atol);
  if (i.fixed_step > 0) s += fmt::format(", step {:g}", i.fixed_step);
  if (i.max_step > 0) s += fmt::format(", max_step {:g}", i.max_step);
  if (p.model->has_constraints()) s += fmt::format(", ideal constraints ({} efforts)", p.model->num_multipliers());
  if (!p.model->algebraic_loops().empty()) s += ", algebraic loops solved";
  return s;
}

int Compare(const CompareCommand& c) {
  // Both models are loaded and compiled, and the report's folder checked, before anything runs.
  PreparedRun pa = PrepareRun(c.a, c.run);
  PreparedRun pb = PrepareRun(c.b, c.run);
  if (pa.options.t_end != pb.options.t_end || pa.options.dt != pb.options.dt)
    throw CliExit{kExitUsage, fmt::format("the models' output grids differ (A: t_end {:g} s, dt {:g} s; B: t_end {:g} s, dt {:g} s): "
                                          "give --t-end and --dt",
                                          pa.options.t_end, pa.options.dt, pb.options.t_end, pb.options.dt)};
  if (!c.out.empty()) {
    RefuseWritingOnto({c.out}, {c.a, c.b});
    const fs::path out(c.out);
    if (out.has_parent_path() && !fs::is_directory(out.parent_path()))
      throw CliExit{kExitIo, fmt::format("cannot write '{}': no folder '{}'", c.out, out.parent_path().string())};
    if (fs::is_directory(out)) throw CliExit{kExitIo, fmt::format("cannot write '{}': it is a directory", c.out)};  // before both runs
  }
  mb::RecordingObserver ra, rb;
  for (auto [p, rec, name] : {std::tuple{&pa, &ra, "A"}, std::tuple{&pb, &rb, "B"}}) {
    mb::RunSummary summary;
    try {
      summary = mb::Simulate(*p->model, p->options, *rec);
    } catch (const std::invalid_argument& e) {
      throw CliExit{kExitUsage, e.what()};
    }
    if (summary.status == mb::RunStatus::kFailed) {
      std::cerr << fmt::format("error: the simulation of {} ({}) failed {}\n  nothing to compare; nothing was written\n  hint: {}\n",
                               name, p->lm.file, summary.message, FailureHint(p->options, summary.message));
      return kExitSolver;
    }
    if (summary.status == mb::RunStatus::kInterrupted) {
      std::cerr << summary.message << "; nothing was written\n";
      return InterruptedExitCode();
    }
    for (const std::string& w : summary.warnings) std::cerr << fmt::format("warning: {} ({}): {}\n", name, p->lm.file, w);
  }
  mb::ComparisonReport report;
  try {
    report = mb::CompareRecordings(ra, rb);
  } catch (const std::invalid_argument& e) {
    throw CliExit{kExitUsage, e.what()};
  }
  mb::SortComparison(report, c.sort == "name" ? mb::ComparisonOrder::kName : mb::ComparisonOrder::kRelative);
  const size_t shown = c.top ? std::min<size_t>(*c.top, report.columns.size()) : report.columns.size();
  const std::string order = c.sort == "name" ? "by name" : "by relative difference, largest first";

  std::cout << fmt::format("A: {} (model '{}'; {})\nB: {} (model '{}'; {})\n", c.a, pa.lm.graph.name(), RunSettings(pa), c.b,
                           pb.lm.graph.name(), RunSettings(pb));
  std::cout << fmt::format("{} samples from t = {:g} to {:g} s (dt {:g} s); {} columns in both, {}{}\n", report.samples, report.t_first,
                           report.t_last, pa.options.dt, report.columns.size(), order,
                           shown < report.columns.size() ? fmt::format(", top {} shown", shown) : "");
  size_t width = 6;
  for (size_t k = 0; k < shown; ++k)
    width = std::max(width, report.columns[k].name.size() + report.columns[k].unit.size() + 3);
  width = std::min<size_t>(width, 48);
  std::cout << fmt::format("  {:<{}}  {:>12}  {:>10}  {:>12}  {:>10}\n", "column", width, "max |A-B|", "at t [s]", "scale max|A|",
                           "relative");
  for (size_t k = 0; k < shown; ++k) {
    const mb::ColumnComparison& col = report.columns[k];
    std::cout << fmt::format("  {:<{}}  {:>12.4g}  {:>10.6g}  {:>12.4g}  {:>10.3g}{}\n", col.name + " [" + col.unit + "]", width,
                             col.max_abs_diff, col.time, col.scale, col.relative,
                             col.unit_b != col.unit ? fmt::format("  (unit in B: {})", col.unit_b) : "");
  }
  auto list = [](const std::vector<std::string>& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
  };
  std::cout << fmt::format("only in A ({}){}{}\n", report.only_in_a.size(), report.only_in_a.empty() ? "" : ": ", list(report.only_in_a));
  std::cout << fmt::format("only in B ({}){}{}\n", report.only_in_b.size(), report.only_in_b.empty() ? "" : ": ", list(report.only_in_b));
  if (const mb::ColumnComparison* w = report.Worst())
    std::cout << fmt::format("largest relative difference: {:.3g} in {} at t = {:g} s\n", w->relative, w->name, w->time);

  if (!c.out.empty()) {
    std::string csv = fmt::format(
        "# multibond compare; A: {} ({}); B: {} ({}); t_end {:g} s, dt {:g} s, jit {}, all_variables {}, sort {}, top {}; multibond {}\n",
        c.a, RunSettings(pa), c.b, RunSettings(pb), pa.options.t_end, pa.options.dt, c.run.jit, c.run.all_variables, c.sort,
        c.top ? std::to_string(*c.top) : "all", mb::kVersion);
    csv += fmt::format("# only in A ({}): {}\n# only in B ({}): {}\n", report.only_in_a.size(), list(report.only_in_a),
                       report.only_in_b.size(), list(report.only_in_b));
    csv += "column,unit,max_abs_diff,time,scale,relative_diff\n";
    for (size_t k = 0; k < shown; ++k) {
      const mb::ColumnComparison& col = report.columns[k];
      csv += fmt::format("{},{},{},{},{},{}\n", mb::CsvCell(col.name), mb::CsvCell(col.unit), col.max_abs_diff, col.time, col.scale, col.relative);
    }
    try {
      mb::WriteFileAtomic(c.out, csv);
    } catch (const std::exception& e) {
      throw CliExit{kExitIo, e.what()};
    }
    std::cout << "wrote " << c.out << '\n';
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  // One way to stop in every phase: loading, compiling (the compiler is ended), integrating (the
  // rows so far are kept), writing (temporaries removed); exit 128 + the signal.
  mb::InstallStopHandlers();
  CLI::App app{"multibond: model and simulate mechanisms as multibond graphs", "multibond"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "multibond " + std::string(mb::kVersion));  // as `multibond version` prints it

  std::string model, format = "text", out;
  CheckArgs ca;
  auto* check = app.add_subcommand("check", "Assign causality, print it and the state variables; exit 1 unless integrally causal");
  check->add_option("MODEL", ca.model, "model file (YAML)")->required();
  AddConstraintsOption(check, ca.constraints);
  AddLoopsOption(check, ca.loops);
  check->add_flag("--suggest", ca.suggest,
                  "for derivative causality: list compliant couplings (a C and an R each, greedy: each one needed) that remove "
                  "it, with K and R from --frequency and --damping-ratio");
  check->add_option("--frequency", ca.frequency, "--suggest: target natural frequency of each coupling [Hz] (default 100)")
      ->check(kPositive);
  check->add_option("--damping-ratio", ca.damping_ratio, "--suggest: target damping ratio of each coupling (default 0.7)")
      ->check(kNonNegative);
  check->add_option("--write", ca.write, "--suggest: write the repaired model file to FILE (implies --suggest)")->type_name("FILE")->check(kPathName);

  auto* eq = app.add_subcommand("equations", "Print the state equations generated from the graph, with their causal paths");
  eq->add_option("MODEL", model, "model file (YAML)")->required();
  eq->add_option("--format", format, "text or latex")->check(CLI::IsMember({"text", "latex"}));
  std::optional<std::string> eq_constraints, eq_loops;
  AddConstraintsOption(eq, eq_constraints);
  AddLoopsOption(eq, eq_loops);

  auto* graph = app.add_subcommand("graph", "Draw the bond graph with causal strokes (Graphviz DOT, and SVG/PNG when dot is installed)");
  graph->add_option("MODEL", model, "model file (YAML)")->required();
  graph->add_option("-o,--output", out, "output file: .dot (or .gv), .svg or .png; an image gets its .dot source next to it")->required()->check(kPathName);

  RunCommand rc;
  auto* run = app.add_subcommand("run", "Simulate and write DIR/results.csv and DIR/run.json");
  run->add_option("MODEL", rc.model, "model file (YAML)")->required();
  run->add_option("-o,--output", rc.out, "output folder")->required()->check(kPathName);
  AddRunOptions(run, rc.run);
  run->add_flag("-q,--quiet", rc.quiet, "no progress and no summary");

  CompareCommand cc;
  auto* compare = app.add_subcommand(
      "compare", "Run two models on one output grid and report, per result column, the largest difference over time");
  compare->add_option("A", cc.a, "model file (YAML); its values give each column's scale")->required();
  compare->add_option("B", cc.b, "model file (YAML)")->required();
  compare->add_option("-o,--output", cc.out, "also write the report as CSV to FILE")->type_name("FILE")->check(kPathName);
  compare->add_option("--sort", cc.sort, "diff: largest relative difference first (default); name: by column name")
      ->check(CLI::IsMember({"diff", "name"}));
  compare->add_option("--top", cc.top, "report only the first N columns")->check(kPositive);
  AddRunOptions(compare, cc.run);

  std::string plot_dir, plot_model;
  auto* plot = app.add_subcommand("plot", "Draw the paper's figures (Figs. 2-33) from a results folder and write DIR/index.html");
  plot->add_option("DIR", plot_dir, "results folder of 'multibond run'")->required();
  plot->add_option("--model", plot_model, "model file, for the bond graph (default: the one named in DIR/run.json)");

  app.add_subcommand("version", "Print the version");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  const std::vector<std::string> args(argv, argv + argc);
  try {
    if (app.got_subcommand("version")) {
      std::cout << "multibond " << mb::kVersion << '\n';
      return kExitOk;
    }
    if (*check) {
      ca.suggest = ca.suggest || ca.write.has_value();
      return Check(ca);
    }
    if (*eq) return Equations(model, format, eq_constraints, eq_loops);
    if (*graph) return Graph(model, out);
    if (*run) return Run(rc, args);
    if (*compare) return Compare(cc);
    if (*plot) {
      const mb::OutputFolder folder(plot_dir, CommandLine(args), /*create=*/false);  // one command at a time
      for (const std::string& stale : folder.removed_stale())
        std::cerr << fmt::format("note: removed '{}', a temporary file of an earlier command that did not finish\n", folder.File(stale));
      mb::PlotOptions po;
      po.model_path = plot_model;
      const mb::PlotReport report = mb::MakePaperFigures(plot_dir, po);
      for (const auto& w : report.warnings) std::cerr << "warning: " << w << '\n';
      if (report.files.empty()) {
        std::cerr << fmt::format("error: no figure drawn from '{}' (see the warnings above); nothing was written\n", plot_dir);
        return kExitIo;
      }
      mb::WriteResultsPage(plot_dir, report);
      std::cout << fmt::format("wrote {} figure files in {}/figures and {}/index.html\n", report.files.size(), plot_dir, plot_dir);
      return kExitOk;
    }
  } catch (const CliExit& e) {
    std::cerr << "error: " << e.message << '\n';
    return e.code;
  } catch (const mb::Interrupted& e) {
    std::cerr << "error: " << e.what() << "; nothing was written\n";
    return e.ExitCode();
  } catch (const mb::ModelError& e) {
    return ModelFailure(e, *run || *graph || *compare || (*check && ca.write));
  } catch (const mb::SolverError& e) {
    std::cerr << "error: solver failure " << e.what() << '\n';
    return kExitSolver;
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitIo;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return kExitIo;
  }
  return kExitUsage;
}
