#include "multibond/io/model_loader.h"

#include "multibond/core/identifier.h"
#include "multibond/core/structure.h"
#include "multibond/core/units.h"
#include "multibond/core/utf8.h"
#include "multibond/io/yaml_bounds.h"
#include "multibond/mech/mechanism.h"
#include "multibond/sim/simulator.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <map>
#include <set>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

namespace multibond {

namespace {

using Env = std::map<std::string, double>;  // submodel parameters in scope

Diagnostic FileSizeError(const std::string& file, std::uint64_t size, const InputLimits& limits) {
  Diagnostic d;
  d.where = {file, 1, 1};
  d.code = "limit.file-size";
  d.message = fmt::format("limit 'file-size' exceeded: the model is {} bytes long (at most {})", size, limits.file_bytes);
  d.hint = RaiseLimitHint("file-size", limits.file_bytes);
  return d;
}

[[noreturn]] void ThrowIo(const std::string& path, const std::string& code, const std::string& message, const std::string& hint) {
  Diagnostic d;
  d.where.file = path;
  d.code = code;  // "io.*": the CLI exits 74 for it, as for any file it cannot read
  d.message = message;
  d.hint = hint;
  throw ModelError(d);
}

const std::vector<std::string> kTopKeys = {"model", "description", "domain", "elements", "bonds", "states", "outputs",
                                           "simulation", "submodels", "gravity", "bodies", "joints", "gears", "drives", "points",
                                           "constraints", "rigid", "algebraic_loops"};
const std::vector<std::string> kCommonKeys = {"type", "dim", "domain", "components", "description"};

class Loader {
 public:
  Loader(std::string file, std::string text, const InputLimits& limits) : file_(std::move(file)), text_(std::move(text)), limits_(limits) {}

  LoadedModel Load() {
    LoadedModel out{BondGraph("model"), {}, {}, file_, text_, {}, nullptr};
    if (text_.size() > limits_.file_bytes) throw ModelError(FileSizeError(file_, text_.size(), limits_));
    // Names, values and comments reach results, run.json and messages: the text must be UTF-8.
    if (const TextProblem t = FindTextProblem(text_); t.found()) {
      sink_.Error("text.encoding", Location(t.offset), "", fmt::format("the model file is not UTF-8 text: {}", t.what),
                  "save the file as UTF-8 (names are ASCII identifiers; other text may use any Unicode character)");
      sink_.ThrowIfErrors();
    }
    YAML::Node root;
    try {
      // Bounded before yaml-cpp builds a tree: node count (aliases expanded), depth, self-aliases.
      if (!CheckYamlBounds(text_, file_, limits_, sink_)) sink_.ThrowIfErrors();
      // A second document (after '---') would be ignored by YAML::Load: a model file holds one.
      const std::vector<YAML::Node> documents = YAML::LoadAll(text_);
      if (documents.size() > 1) {
        const YAML::Mark m = documents[1].Mark();
        sink_.Error({file_, m.line >= 0 ? m.line + 1 : 0, m.column >= 0 ? m.column + 1 : 0}, "",
                    fmt::format("the file holds {} YAML documents; a model file is one", documents.size()),
                    "remove the '---' line (and what follows it, or merge it into the first document)");
        sink_.ThrowIfErrors();
      }
      if (!documents.empty()) root = documents.front();
    } catch (const YAML::Exception& e) {
      sink_.Add(ExplainSyntaxError(e));
      sink_.ThrowIfErrors();
    }
    if (!root.IsMap()) {
      sink_.Error({file_, 1, 1}, "", "a model file must be a YAML mapping with at least 'elements' and 'bonds'",
                  "start from an example in examples/");
      sink_.ThrowIfErrors();
    }
    CheckDuplicateKeys(root, "");
    sink_.ThrowIfErrors();
    CheckKeys(root, kTopKeys, "");
    std::string name = "model";
    if (root["model"]) name = Str(root["model"], "model");
    if (root["model"] && !CheckName(name, Loc(root["model"]), "the model's", false)) name = "model";
    graph_ = BondGraph(name);
    graph_.set_source_file(file_);
    if (root["domain"]) out.compile.default_domain = Domain(root["domain"], "domain");
    if (root["constraints"]) {
      const std::string c = root["constraints"].IsScalar() ? root["constraints"].Scalar() : "";
      if (c == "ideal") out.compile.ideal_constraints = true;
      else if (c != "compliant")
        sink_.Error(Loc(root["constraints"]), "constraints", fmt::format("unknown constraints '{}'", c),
                    "write 'constraints: ideal' (derivative causality solved exactly) or 'constraints: compliant' (the default)");
    }
    if (root["algebraic_loops"]) {
      const std::string c = root["algebraic_loops"].IsScalar() ? root["algebraic_loops"].Scalar() : "";
      if (c == "solve") out.compile.solve_algebraic_loops = true;
      else if (c != "error")
        sink_.Error(Loc(root["algebraic_loops"]), "algebraic_loops", fmt::format("unknown algebraic_loops '{}'", c),
                    "write 'algebraic_loops: solve' (each loop solved as a linear system at every evaluation) or "
                    "'algebraic_loops: error' (the default: a loop is reported and the model refused)");
    }
    if (root["submodels"]) ReadSubmodelDefs(root["submodels"]);
    const bool mechanism = root["bodies"].IsDefined();
    if (mechanism) ReadMechanism(root);
    if (!root["elements"] && !mechanism)
      sink_.Error({file_, 1, 1}, "", "the model has no 'elements' section (nor 'bodies')", "list the elements under 'elements:'");
    if (!root["bonds"] && !mechanism)
      sink_.Error({file_, 1, 1}, "", "the model has no 'bonds' section", "list the bonds under 'bonds:', e.g. '- force -> mass'");
    for (const char* key : {"joints", "gears", "drives", "points", "gravity"})
      if (root[key] && !mechanism) sink_.Error(Loc(root[key]), key, fmt::format("'{}' needs a 'bodies' section", key), "declare the bodies first");
    // Submodel instances, their depth and the elements and bonds they expand to are counted
    // before anything is expanded: an exponential nest is refused in microseconds.
    if (!CheckExpansion(root)) sink_.ThrowIfErrors();
    ReadScope(root, "", Env{}, 0);
    CheckGraphSize(root);
    WarnIfSomeCompliancesAreIgnored();
    if (root["outputs"]) ReadOutputs(root["outputs"]);
    if (root["simulation"]) ReadSimulation(root["simulation"], out.simulation, mechanism);
    if (sink_.has_errors()) {
      // Report the parameter problems of what could be read too, so that one pass shows them all.
      // (Structural problems of a partly read graph would mostly be echoes of the errors above.)
      DiagnosticSink structural;
      AnalyzeStructure(graph_, out.compile.default_domain, structural);
      for (const auto& d : structural.diagnostics())
        if (d.code == "param.range") sink_.Add(d);
    }
    sink_.ThrowIfErrors();
    for (const auto& d : sink_.diagnostics())
      if (d.severity == Diagnostic::Severity::kWarning) out.warnings.push_back(d);
    out.graph = std::move(graph_);
    out.mechanism = mechanism_;
    return out;
  }

 private:
  /// Names become column headers, file names of figures and comments in generated code: every
  /// name follows the identifier grammar (core/identifier.h, docs/model-format.md "Names and
  /// units"). Reports the problem at `where` and returns false.
  /// `names_columns`: the name heads result columns (all but the model's), so 'time' and 'energy' are taken.
  bool CheckName(const std::string& name, const SourceLocation& where, const char* what, bool names_columns = true) {
    if (names_columns && (name == "time" || name == "energy")) {
      // The results' own columns: time, and the energy account energy.work, energy.stored, ...
      sink_.Error("name.invalid", where, name, fmt::format("{} name '{}' is reserved for the results' {} column{}", what, name, name,
                                                          name == "energy" ? "s (energy.work, energy.stored, ...)" : ""),
                  "choose another name");
      return false;
    }
    const std::string problem = IdentifierProblem(name);
    if (problem.empty()) return true;
    const std::string better = SuggestIdentifier(name);
    sink_.Error("name.invalid", where, PrintableExcerpt(name), fmt::format("{} name {}", what, problem),
                fmt::format("a name is a letter or '_', then letters, digits and '_' (at most {} characters){}", kMaxNameLength,
                            better.empty() || better == name ? "" : fmt::format(": e.g. '{}'", better)));
    return false;
  }

  /// Component names head columns too ("<name>.<component>"): identifiers, a leading digit allowed.
  std::vector<std::string> Components(const YAML::Node& n, const std::string& element) {
    std::vector<std::string> out = Words(n, element, "components");
    if (!n.IsSequence()) return out;
    for (size_t i = 0; i < out.size() && i < n.size(); ++i)
      if (const std::string problem = IdentifierProblem(out[i], true); !problem.empty())
        sink_.Error("name.invalid", Loc(n[i]), element, fmt::format("component name '{}' {}", PrintableExcerpt(out[i]), problem),
                    "a component name is letters, digits and '_', e.g. x, y, z or 1, 2, 3");
    return out;
  }

  /// Redundant reactions are shared by compliances only when every constraint has one
  /// (CompiledModel::ShareRedundantEfforts); a partial set is ignored, and the user is told.
  void WarnIfSomeCompliancesAreIgnored() {
    const Element* with = nullptr;
    const Element* without = nullptr;
    for (int i = 0; i < graph_.num_elements(); ++i) {
      const Element& e = graph_.element(i);
      if (e.kind != ElementKind::kSf || !e.constraint) continue;
      if (e.compliance.size() > 0 && !with) with = &e;
      if (e.compliance.size() == 0 && !without) without = &e;
    }
    if (!with || !without) return;
    Diagnostic d;
    d.severity = Diagnostic::Severity::kWarning;
    d.where = with->where;
    d.element = with->name;
    d.code = "constraint.compliance_ignored";
    d.message = fmt::format("the compliance is not used: constraint '{}' has none, and redundant reactions are "
                            "shared by compliances only when every constraint has one (else by the constraints' mobilities)",
                            without->name);
    d.hint = fmt::format("give '{}' (and every other constraint) a compliance (a rigid joint or mesh: its K), or remove them all",
                         without->name);
    sink_.Add(d);
  }

  /// What a scope expands to: submodel instances (nested ones included), the depth of their
  /// nesting, elements and bonds. Saturates at kCountCap.
  struct Expansion {
    std::uint64_t instances = 0, depth = 0, elements = 0, bonds = 0;
  };
  static constexpr std::uint64_t kCountCap = std::uint64_t{1} << 62;
  static std::uint64_t Add(std::uint64_t a, std::uint64_t b) { return std::min(kCountCap, a + std::min(b, kCountCap)); }

  Expansion Expand(const YAML::Node& scope, std::map<std::string, Expansion>& memo, std::set<std::string>& visiting) {
    Expansion x;
    const YAML::Node elements = scope["elements"];
    if (elements.IsMap())
      for (const auto& kv : elements) {
        const YAML::Node type = kv.second.IsMap() ? kv.second["type"] : YAML::Node();
        const auto def = type && type.IsScalar() ? submodels_.find(type.Scalar()) : submodels_.end();
        if (def == submodels_.end()) {
          x.elements = Add(x.elements, 1);
          continue;
        }
        if (visiting.count(def->first)) continue;  // a submodel that contains itself: said by Instantiate
        if (!memo.count(def->first)) {
          visiting.insert(def->first);
          memo[def->first] = Expand(def->second.node, memo, visiting);
          visiting.erase(def->first);
        }
        const Expansion& inner = memo[def->first];
        x.instances = Add(x.instances, Add(inner.instances, 1));
        x.depth = std::max(x.depth, Add(inner.depth, 1));
        x.elements = Add(x.elements, inner.elements);
        x.bonds = Add(x.bonds, inner.bonds);
      }
    if (scope["bonds"].IsSequence()) x.bonds = Add(x.bonds, scope["bonds"].size());
    return x;
  }

  /// The limit `name` (InputLimits) exceeded by `found` (kCountCap: "more than `limit`").
  void LimitError(const char* name, const SourceLocation& where, std::uint64_t found, std::uint64_t limit, const std::string& what) {
    const std::string count = found >= kCountCap ? fmt::format("more than {}", limit) : fmt::format("{}", found);
    sink_.Error(fmt::format("limit.{}", name), where, "", fmt::format("limit '{}' exceeded: {} {} (at most {})", name, count, what, limit),
                RaiseLimitHint(name, limit));
  }

  /// Counts what the model's submodels expand to, before any is expanded. False if a limit is exceeded.
  bool CheckExpansion(const YAML::Node& root) {
    if (submodels_.empty()) return true;
    std::map<std::string, Expansion> memo;
    std::set<std::string> visiting;
    const Expansion x = Expand(root, memo, visiting);
    const SourceLocation where = root["elements"] ? Loc(root["elements"]) : SourceLocation{file_, 1, 1};
    bool ok = true;
    if (x.instances > limits_.instances) ok = false, LimitError("instances", where, x.instances, limits_.instances, "submodel instances, nested ones included");
    if (x.depth > limits_.depth) ok = false, LimitError("depth", where, x.depth, limits_.depth, "submodels nested in submodels");
    if (x.elements > limits_.elements) ok = false, LimitError("elements", where, x.elements, limits_.elements, "elements once the submodels are expanded");
    if (x.bonds > limits_.bonds) ok = false, LimitError("bonds", where, x.bonds, limits_.bonds, "bonds once the submodels are expanded");
    return ok;
  }

  /// The expanded graph (mechanism parts included) within the element and bond limits.
  void CheckGraphSize(const YAML::Node& root) {
    const SourceLocation where = root["bodies"] ? Loc(root["bodies"]) : root["elements"] ? Loc(root["elements"]) : SourceLocation{file_, 1, 1};
    const auto elements = static_cast<std::uint64_t>(graph_.num_elements()), bonds = static_cast<std::uint64_t>(graph_.num_bonds());
    if (elements > limits_.elements) LimitError("elements", where, elements, limits_.elements, "elements in the expanded bond graph");
    if (bonds > limits_.bonds) LimitError("bonds", where, bonds, limits_.bonds, "bonds in the expanded bond graph");
  }

  struct SubmodelDef {
    YAML::Node node;
    Env defaults;
    std::set<std::string> ports;
    bool ports_in_error = false;  ///< a port names no element (said at the definition, not at every use)
  };

  /// yaml-cpp reports a syntax error where it noticed it, often a line after the cause (an
  /// unclosed '{' is found at the next key). Where the cause can be told from the text, the
  /// diagnostic says it: the bracket that is not closed, or closed by the wrong one, and the line
  /// indented deeper than the block it is in.
  Diagnostic ExplainSyntaxError(const YAML::Exception& e) const {
    Diagnostic d;
    d.where = Loc(e.mark);
    d.message = "YAML syntax error: " + e.msg;
    d.hint = "check indentation, colons and brackets near this place";
    d.code = "yaml.syntax";
    if (e.mark.line < 0) return d;
    // Offset of the error in the text, from its line and column.
    size_t at = 0;
    for (int line = 0; line < e.mark.line; ++line) {
      const size_t end = text_.find('\n', at);
      if (end == std::string::npos) return d;  // fewer lines than the mark says
      at = end + 1;
    }
    at = std::min(text_.size(), at + static_cast<size_t>(std::max(0, e.mark.column)));
    // The flow brackets still open at the error (quotes and comments skipped).
    struct Open {
      char c;
      size_t pos;
    };
    std::vector<Open> open;
    char quote = 0;
    for (size_t i = 0; i < at; ++i) {
      const char c = text_[i];
      if (quote) {
        if (c == quote && !(quote == '"' && i > 0 && text_[i - 1] == '\\')) quote = 0;
        else if (c == '\n') quote = 0;  // flow scalars do not span lines here; do not run away
        continue;
      }
      if (c == '"' || c == '\'') quote = c;
      else if (c == '#' && (i == 0 || text_[i - 1] == ' ' || text_[i - 1] == '\n')) i = std::min(at, text_.find('\n', i)) - 1;
      else if ((c == '{' || c == '[') && OpensFlow(i)) open.push_back({c, i});
      else if ((c == '}' || c == ']') && !open.empty()) open.pop_back();
    }
    auto location = [&](size_t pos) { return Location(pos); };
    const char here = at < text_.size() ? text_[at] : '\0';
    if (!open.empty() && (here == '}' || here == ']') && here != (open.back().c == '{' ? '}' : ']')) {
      d.details.push_back(fmt::format("the '{}' opened at {} is closed here by '{}'", open.back().c, location(open.back().pos).ToString(), here));
      d.hint = fmt::format("close it with '{}'", open.back().c == '{' ? '}' : ']');
    } else if (!open.empty() && e.msg.find("flow") != std::string::npos && e.msg.find("not found") != std::string::npos) {
      const Open& o = open.back();
      d.where = location(o.pos);
      d.details.push_back(fmt::format("the '{}' opened here is not closed (yaml-cpp noticed it at {})", o.c, Loc(e.mark).ToString()));
      d.hint = fmt::format("close it with '{}' (a flow collection may continue on the next lines, but must end)", o.c == '{' ? '}' : ']');
    } else if (e.msg.find("end of map not found") != std::string::npos || e.msg.find("end of sequence not found") != std::string::npos) {
      // A block collection broken by a line indented deeper than its siblings.
      auto indent = [&](size_t line_start) {
        size_t k = line_start;
        while (k < text_.size() && text_[k] == ' ') ++k;
        return k - line_start;
      };
      const size_t line_start = at == 0 ? 0 : text_.rfind('\n', at - 1) + 1;
      size_t prev = line_start;  // the previous line with content
      while (prev > 0) {
        prev = prev >= 2 ? text_.rfind('\n', prev - 2) + 1 : 0;
        const size_t k = prev + indent(prev);
        if (k < text_.size() && text_[k] != '\n' && text_[k] != '#') break;
      }
      const size_t prev_end = text_.find('\n', prev);
      const std::string prev_line = text_.substr(prev, prev_end == std::string::npos ? std::string::npos : prev_end - prev);
      const size_t last = prev_line.find_last_not_of(" \r");
      const bool opens_block = last != std::string::npos && prev_line[last] == ':';
      if (prev < line_start && indent(line_start) > indent(prev) && !opens_block) {
        d.where = location(line_start + indent(line_start));
        d.details.push_back(fmt::format("this line is indented by {} spaces, the one before it (line {}) by {}, and that one "
                                        "does not open a block", indent(line_start), location(prev).line, indent(prev)));
        d.hint = "indent entries of the same mapping or list equally";
      }
    }
    return d;
  }

  /// file:line:column of the byte at `pos` of the text (the column counts bytes).
  SourceLocation Location(size_t pos) const {
    pos = std::min(pos, text_.size());
    const size_t line_start = pos == 0 ? 0 : text_.rfind('\n', pos - 1) + 1;
    const int line = static_cast<int>(std::count(text_.begin(), text_.begin() + static_cast<long>(pos), '\n')) + 1;
    return SourceLocation{file_, line, static_cast<int>(pos - line_start) + 1};
  }

  /// A '{' or '[' at text_[i] starts a flow collection when it starts a value: after ':', ',',
  /// '-', another bracket or the line's indentation. Inside a plain scalar ("uses {x}") it is text.
  bool OpensFlow(size_t i) const {
    while (i > 0 && text_[i - 1] == ' ') --i;
    return i == 0 || std::string(":,-[{\n").find(text_[i - 1]) != std::string::npos;
  }

  SourceLocation Loc(const YAML::Mark& m) const {
    if (m.line < 0) return {file_, 0, 0};
    return {file_, m.line + 1, m.column + 1};
  }
  SourceLocation Loc(const YAML::Node& n) const { return Loc(n.Mark()); }

  /// A key given twice in one mapping: YAML forbids it, and yaml-cpp would keep the first value
  /// and drop the other without a word. Checked over the whole document before it is read.
  /// Element names (the keys of an 'elements' mapping) have their own check, with the same
  /// information (ReadScope: "duplicate element name").
  void CheckDuplicateKeys(const YAML::Node& node, const std::string& path, bool element_names = false) {
    if (node.IsSequence()) {
      for (size_t i = 0; i < node.size(); ++i) CheckDuplicateKeys(node[i], fmt::format("{}[{}]", path, i));
      return;
    }
    if (!node.IsMap()) return;
    std::map<std::string, SourceLocation> seen;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) continue;
      const std::string key = kv.first.Scalar();
      const std::string where = path.empty() ? key : path + "." + key;
      if (key == "<<") {  // yaml-cpp reads a merge key as an ordinary key
        sink_.Error(Loc(kv.first), path, "YAML merge keys ('<<: *anchor') are not supported",
                    "write the keys out (an anchor and alias of a whole value, '&a' and '*a', do work)");
        continue;
      }
      const auto [first, fresh] = seen.emplace(key, Loc(kv.first));
      if (!fresh && !element_names) {
        Diagnostic d;
        d.where = Loc(kv.first);
        d.element = where;
        d.message = fmt::format("duplicate key '{}': YAML allows a key once per mapping, and only the first value would be used", key);
        d.details.push_back("first given at " + first->second.ToString());
        d.hint = "remove one of the two, or merge them";
        d.code = "yaml.duplicate_key";
        sink_.Add(d);
      }
      CheckDuplicateKeys(kv.second, where, key == "elements");
    }
  }

  void CheckKeys(const YAML::Node& map, const std::vector<std::string>& allowed, const std::string& element) {
    if (!map.IsMap()) return;
    for (const auto& kv : map) {
      const std::string key = kv.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      if (key == "<<") continue;  // said by CheckDuplicateKeys
      const std::string guess = DidYouMean(key, allowed);
      std::string allowed_list;
      for (const auto& a : allowed) allowed_list += (allowed_list.empty() ? "" : ", ") + a;
      sink_.Error(Loc(kv.first), element, fmt::format("unknown key '{}'", key),
                  guess.empty() ? "known keys here: " + allowed_list : fmt::format("did you mean '{}'?", guess));
    }
  }

  /// What a node is, for messages: "a number", "a list", "nothing"...
  static std::string Describe(const YAML::Node& n) {
    if (n.IsNull()) return "nothing";
    if (n.IsSequence()) return "a list";
    if (n.IsMap()) return "a mapping";
    return fmt::format("'{}'", n.Scalar());
  }

  /// A list of words (component names, ports); anything else is reported.
  std::vector<std::string> Words(const YAML::Node& n, const std::string& element, const char* what) {
    std::vector<std::string> out;
    if (!n.IsSequence()) {
      sink_.Error(Loc(n), element, fmt::format("'{}' must be a list", what), fmt::format("write e.g. {}: [x, y]", what));
      return out;
    }
    for (const auto& w : n) {
      if (!w.IsScalar()) {
        sink_.Error(Loc(w), element, fmt::format("each entry of '{}' is a single word", what));
        continue;
      }
      out.push_back(w.Scalar());
    }
    return out;
  }

  std::string Str(const YAML::Node& n, const std::string& element) {
    if (!n.IsScalar()) {
      sink_.Error(Loc(n), element, "expected a text value", "write a single word or a quoted string");
      return {};
    }
    return n.Scalar();
  }

  std::string Domain(const YAML::Node& n, const std::string& element) {
    const std::string d = Str(n, element);
    const auto& known = KnownDomains();
    if (!d.empty() && std::find(known.begin(), known.end(), d) == known.end()) {
      const std::string guess = DidYouMean(d, known);
      sink_.Error(Loc(n), element, fmt::format("unknown domain '{}'", d),
                  guess.empty() ? "use translation, rotation, electrical, hydraulic or generic" : fmt::format("did you mean '{}'?", guess));
    }
    return d == "generic" ? "" : d;
  }

  /// A finite number, or a $parameter of the enclosing submodel.
  double Number(const YAML::Node& n, const std::string& element, const Env& env, bool* ok = nullptr) {
    auto fail = [&](const std::string& msg, const std::string& hint) {
      sink_.Error(Loc(n), element, msg, hint);
      if (ok) *ok = false;
      return 0.0;
    };
    if (!n.IsScalar()) return fail("expected a number", "write a plain number such as 1.5 or 2e-3");
    const std::string s = n.Scalar();
    if (!s.empty() && s[0] == '$') {
      const auto it = env.find(s.substr(1));
      if (it == env.end()) return fail(fmt::format("unknown parameter '{}'", s), "declare it under the submodel's 'parameters'");
      return it->second;
    }
    if (s == ".nan" || s == ".NaN" || s == ".NAN" || s == ".inf" || s == ".Inf" || s == "-.inf" || s == "+.inf" || s == "-.Inf")
      return fail(fmt::format("'{}' is not a finite number", s), "NaN and infinities are not allowed in a model");
    const char* begin = s.c_str();
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (s.empty() || end != begin + s.size()) return fail(fmt::format("expected a number, got '{}'", s), "write a plain number such as 1.5 or 2e-3");
    if (!std::isfinite(v)) return fail(fmt::format("'{}' is not a finite number", s), "NaN and infinities are not allowed in a model");
    // A subnormal number (0 < |v| < 2.2e-308) is no physical quantity: its inverse is infinite,
    // and arithmetic on it loses its digits.
    if (v != 0.0 && std::abs(v) < DBL_MIN)
      return fail(fmt::format("'{}' is too small to compute with (a subnormal number, below {:g} in magnitude)", s, DBL_MIN),
                  "write 0, or a value of a sensible size in SI units");
    return v;
  }

  Eigen::VectorXd Vector(const YAML::Node& n, const std::string& element, const Env& env) {
    if (n.IsScalar()) return Eigen::VectorXd::Constant(1, Number(n, element, env));
    if (!n.IsSequence()) {
      sink_.Error(Loc(n), element, "expected a list of numbers", "write e.g. [0, 0, 1]");
      return {};
    }
    Eigen::VectorXd v(static_cast<Eigen::Index>(n.size()));
    for (size_t i = 0; i < n.size(); ++i) v(static_cast<Eigen::Index>(i)) = Number(n[i], element, env);
    return v;
  }

  Eigen::MatrixXd Matrix(const YAML::Node& n, const std::string& element, const Env& env) {
    if (!n.IsSequence() || n.size() == 0 || !n[0].IsSequence()) {
      sink_.Error(Loc(n), element, "expected a matrix (a list of rows)", "write e.g. [[1, 0], [0, 1]]");
      return {};
    }
    const size_t rows = n.size(), cols = n[0].size();
    Eigen::MatrixXd m(rows, cols);
    for (size_t r = 0; r < rows; ++r) {
      if (!n[r].IsSequence() || n[r].size() != cols) {
        sink_.Error(Loc(n[r]), element, fmt::format("matrix row {} has {} entries, the first row {}", r + 1, n[r].IsSequence() ? n[r].size() : 1, cols),
                    "every row of a matrix has the same length");
        return {};
      }
      for (size_t c = 0; c < cols; ++c) m(r, c) = Number(n[r][c], element, env);
    }
    return m;
  }

  /// A scalar, a diagonal given as a list, or a full matrix.
  Param ReadParam(const YAML::Node& n, const std::string& element, const Env& env) {
    if (n.IsScalar()) return Param::Scalar(Number(n, element, env));
    if (n.IsSequence() && n.size() > 0 && n[0].IsSequence()) return Param::Matrix(Matrix(n, element, env));
    if (n.IsSequence()) {
      const Eigen::VectorXd d = Vector(n, element, env);
      return Param::Matrix(d.asDiagonal());
    }
    sink_.Error(Loc(n), element, "expected a number, a list (diagonal) or a matrix", "write e.g. 2.0, [1, 2, 3] or [[1, 0], [0, 1]]");
    return Param::Scalar(1.0);
  }

  TimeFunction ReadTimeFunction(const YAML::Node& n, const std::string& element, const Env& env) {
    if (n.IsScalar()) return TimeFunction::Constant(Number(n, element, env));
    if (!n.IsMap() || n.size() != 1) {
      sink_.Error(Loc(n), element, "expected a number or one of {step: ...}, {ramp: ...}, {sine: ...}, {table: ...}",
                  "e.g. effort: {step: {value: 1, at: 0}}");
      return {};
    }
    const std::string kind = n.begin()->first.Scalar();
    const YAML::Node v = n.begin()->second;
    auto get = [&](const char* key, double dflt) { return v[key] ? Number(v[key], element, env) : dflt; };
    // step, ramp and sine take a mapping of settings ({} keeps every default); step also a number.
    auto settings = [&](const char* example) {
      if (v.IsMap()) return true;
      sink_.Error(Loc(v), element, fmt::format("'{}' takes a mapping of settings, not {}", kind, Describe(v)),
                  fmt::format("write e.g. {{{}: {}}}", kind, example));
      return false;
    };
    if (kind == "step") {
      if (v.IsScalar()) return TimeFunction::Step(Number(v, element, env));
      if (!settings("{value: 5, at: 1}")) return {};
      CheckKeys(v, {"value", "at", "before"}, element);
      return TimeFunction::Step(get("value", 1.0), get("at", 0.0), get("before", 0.0));
    }
    if (kind == "ramp") {
      if (!settings("{slope: 2, start: 1}")) return {};
      CheckKeys(v, {"slope", "start", "offset"}, element);
      return TimeFunction::Ramp(get("slope", 1.0), get("start", 0.0), get("offset", 0.0));
    }
    if (kind == "sine") {
      if (!settings("{amplitude: 0.1, frequency: 50}")) return {};
      CheckKeys(v, {"amplitude", "frequency", "phase", "offset"}, element);
      return TimeFunction::Sine(get("amplitude", 1.0), get("frequency", 1.0), get("phase", 0.0), get("offset", 0.0));
    }
    if (kind == "table") {
      std::vector<double> t, val;
      if (!v.IsSequence() || v.size() < 2) {
        sink_.Error(Loc(v), element, "a table needs at least two [time, value] rows", "write e.g. table: [[0, 0], [1, 5]]");
        return {};
      }
      for (const auto& row : v) {
        if (!row.IsSequence() || row.size() != 2) {
          sink_.Error(Loc(row), element, "a table row is [time, value]");
          return {};
        }
        t.push_back(Number(row[0], element, env));
        val.push_back(Number(row[1], element, env));
        if (t.size() > 1 && !(t.back() > t[t.size() - 2])) sink_.Error(Loc(row), element, "table times must increase strictly");
      }
      return TimeFunction::Table(std::move(t), std::move(val));
    }
    const std::string guess = DidYouMean(kind, {"step", "ramp", "sine", "table"});
    sink_.Error(Loc(n.begin()->first), element, fmt::format("unknown time function '{}'", kind),
                guess.empty() ? "use step, ramp, sine or table" : fmt::format("did you mean '{}'?", guess));
    return {};
  }

  SourceValue ReadSource(const YAML::Node& n, const std::string& element, const Env& env) {
    SourceValue v;
    if (n.IsSequence())
      for (const auto& c : n) v.components.push_back(ReadTimeFunction(c, element, env));
    else
      v.components.push_back(ReadTimeFunction(n, element, env));
    return v;
  }

  Eigen::MatrixXd Selection(const YAML::Node& n, const std::string& element) {
    static const std::map<std::string, int> kAxes = {{"x", 0}, {"y", 1}, {"z", 2}, {"0", 0}, {"1", 1}, {"2", 2}};
    if (!n.IsSequence() || n.size() == 0 || n.size() > 3) {
      sink_.Error(Loc(n), element, "rows must be a list of axes", "write e.g. rows: [y, z]");
      return {};
    }
    Eigen::MatrixXd s = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n.size()), 3);
    for (size_t i = 0; i < n.size(); ++i) {
      const auto it = kAxes.find(n[i].Scalar());
      if (it == kAxes.end()) {
        sink_.Error(Loc(n[i]), element, fmt::format("unknown axis '{}'", n[i].Scalar()), "axes are x, y, z");
        continue;
      }
      s(static_cast<Eigen::Index>(i), it->second) = 1.0;
    }
    return s;
  }

  Modulus ReadModulus(const YAML::Node& n, const std::string& element, const std::string& prefix, const Env& env) {
    Modulus m;
    if (!n.IsMap()) {
      sink_.Error(Loc(n), element, "modulus must be a mapping",
                  "e.g. {rotation: A.R, transpose: true}, {lever: A.R, r: [0.1, 0, 0]} or {matrix: [[...]]}");
      return m;
    }
    CheckKeys(n, {"rotation", "transpose", "lever", "r", "matrix", "rows", "left", "right", "scale"}, element);
    const int forms = (n["matrix"] ? 1 : 0) + (n["rotation"] ? 1 : 0) + (n["lever"] ? 1 : 0);
    if (forms > 1) sink_.Error(Loc(n), element, "give exactly one of 'matrix', 'rotation' and 'lever'");
    if (n["rows"] && n["left"]) sink_.Error(Loc(n), element, "give either 'rows' or 'left', not both");
    if (n["transpose"] && !n["rotation"]) sink_.Error(Loc(n["transpose"]), element, "'transpose' goes with 'rotation'");
    if (n["r"] && !n["lever"]) sink_.Error(Loc(n["r"]), element, "'r' goes with 'lever'");
    if (n["right"] && !n["rotation"]) sink_.Error(Loc(n["right"]), element, "'right' goes with 'rotation'");
    if (n["scale"]) m.scale = Number(n["scale"], element, env);
    if (n["rows"]) m.left = Selection(n["rows"], element);
    if (n["left"]) m.left = Matrix(n["left"], element, env);
    if (n["right"]) {
      m.right = Matrix(n["right"], element, env);
      if (m.right.size() > 0 && (m.right.rows() != 3 || m.right.cols() > 3))
        sink_.Error(Loc(n["right"]), element, "'right' must be a 3 x n matrix with n <= 3");
    }
    if (n["matrix"]) {
      m.kind = Modulus::Kind::kConstant;
      m.constant = Matrix(n["matrix"], element, env);
    } else if (n["rotation"]) {
      m.kind = Modulus::Kind::kRotation;
      m.rotation = Qualify(prefix, Str(n["rotation"], element));
      if (n["transpose"]) m.transpose = Bool(n["transpose"], element);
    } else if (n["lever"]) {
      m.kind = Modulus::Kind::kLever;
      m.rotation = Qualify(prefix, Str(n["lever"], element));
      if (!n["r"]) sink_.Error(Loc(n), element, "a lever modulus needs 'r', the point in the body frame", "add r: [x, y, z]");
      else {
        const Eigen::VectorXd r = Vector(n["r"], element, env);
        if (r.size() == 3) m.lever = r;
        else sink_.Error(Loc(n["r"]), element, "r must have 3 components");
      }
    } else {
      sink_.Error(Loc(n), element, "modulus needs one of 'rotation', 'lever' or 'matrix'");
    }
    if (m.left.size() > 0 && m.kind == Modulus::Kind::kConstant && m.left.cols() != m.constant.rows())
      sink_.Error(Loc(n), element, "left matrix and modulus matrix do not fit together");
    if (m.left.size() > 0 && m.kind != Modulus::Kind::kConstant && m.left.cols() != 3)
      sink_.Error(Loc(n), element, fmt::format("'left' must have 3 columns here (got {})", m.left.cols()));
    return m;
  }

  bool Bool(const YAML::Node& n, const std::string& element) {
    const std::string s = n.IsScalar() ? n.Scalar() : "";
    if (s == "true" || s == "True" || s == "TRUE" || s == "yes") return true;
    if (s == "false" || s == "False" || s == "FALSE" || s == "no") return false;
    sink_.Error(Loc(n), element, "expected true or false");
    return false;
  }

  static std::string Qualify(const std::string& prefix, const std::string& local) {
    return prefix.empty() ? local : prefix + "." + local;
  }

  void ReadSubmodelDefs(const YAML::Node& n) {
    if (!n.IsMap()) {
      sink_.Error(Loc(n), "submodels", "expected a mapping of submodel names to definitions");
      return;
    }
    for (const auto& kv : n) {
      const std::string name = kv.first.Scalar();
      const YAML::Node def = kv.second;
      if (!CheckName(name, Loc(kv.first), "a submodel's")) continue;
      if (!def.IsMap()) {
        sink_.Error(Loc(def), name, "a submodel definition is a mapping with parameters, ports, elements and bonds");
        continue;
      }
      CheckKeys(def, {"description", "parameters", "ports", "elements", "bonds", "states"}, name);
      if (ParseKind(name)) sink_.Error(Loc(kv.first), name, "a submodel cannot be named like an element kind");
      SubmodelDef sd{def, {}, {}};
      if (def["parameters"]) {
        if (!def["parameters"].IsMap())
          sink_.Error(Loc(def["parameters"]), name, "'parameters' maps each name to its default value", "write e.g. parameters: {m: 1.0}");
        else
          for (const auto& p : def["parameters"])
            if (CheckName(p.first.Scalar(), Loc(p.first), "a parameter's", false)) sd.defaults[p.first.Scalar()] = Number(p.second, name, Env{});
      }
      if (def["ports"])
        for (const auto& p : Words(def["ports"], name, "ports")) sd.ports.insert(p);
      // A port names one of the definition's elements: said here, once, not at every use.
      if (def["ports"] && def["ports"].IsSequence() && def["elements"] && def["elements"].IsMap()) {
        std::vector<std::string> locals;
        for (const auto& e : def["elements"]) locals.push_back(e.first.Scalar());
        for (const auto& p : def["ports"]) {
          if (!p.IsScalar() || std::find(locals.begin(), locals.end(), p.Scalar()) != locals.end()) continue;
          sd.ports_in_error = true;
          const std::string guess = DidYouMean(p.Scalar(), locals);
          sink_.Error(Loc(p), name, fmt::format("port '{}' is not one of the submodel's elements", p.Scalar()),
                      guess.empty() ? "a port names an element under the submodel's 'elements'" : fmt::format("did you mean '{}'?", guess));
        }
      }
      submodels_[name] = sd;
    }
  }

  /// Reads the elements, bonds and states of a model or of a submodel instance under `prefix`.
  void ReadScope(const YAML::Node& scope, const std::string& prefix, const Env& env, int depth) {
    if (static_cast<std::uint64_t>(depth) > limits_.depth) return;  // said by CheckExpansion before expanding
    const YAML::Node elements = scope["elements"];
    if (elements && !elements.IsMap()) {
      sink_.Error(Loc(elements), "elements", "'elements' must be a mapping of names to element specifications",
                  "write e.g. 'mass: {type: I, inertia: 1.0}'");
    } else if (elements) {
      std::map<std::string, SourceLocation> seen;
      for (const auto& kv : elements) {
        const std::string local = kv.first.Scalar();
        if (seen.count(local)) {
          Diagnostic d;
          d.where = Loc(kv.first);
          d.element = local;
          d.message = "duplicate element name";
          d.details.push_back("first defined at " + seen[local].ToString());
          d.hint = "give every element a unique name";
          sink_.Add(d);
          continue;
        }
        seen[local] = Loc(kv.first);
        // An element refused here has had its error: the bonds that name it do not add another.
        const std::string qualified = Qualify(prefix, local);
        if (!CheckName(local, Loc(kv.first), "an element's")) {
          refused_elements_.insert(qualified);
          continue;
        }
        ReadElement(qualified, kv.second, Loc(kv.first), prefix, env, depth);
        if (graph_.Find(qualified) < 0 && !instance_where_.count(qualified)) refused_elements_.insert(qualified);
      }
    }
    if (scope["states"]) ReadStates(scope["states"], prefix, env);
    const YAML::Node bonds = scope["bonds"];
    if (bonds && !bonds.IsSequence()) {
      sink_.Error(Loc(bonds), "bonds", "'bonds' must be a list", "write e.g. '- force -> mass'");
    } else if (bonds) {
      for (const auto& b : bonds) ReadBond(b, prefix, env);
    }
  }

  void ReadElement(const std::string& name, const YAML::Node& spec, const SourceLocation& where, const std::string& prefix,
                   const Env& env, int depth) {
    if (!spec.IsMap()) {
      sink_.Error(where, name, "an element is a mapping with at least a 'type'", "write e.g. '{type: C, stiffness: 100}'");
      return;
    }
    if (!spec["type"]) {
      sink_.Error(where, name, "element has no 'type'", "add type: Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name");
      return;
    }
    const std::string type = spec["type"].Scalar();
    if (submodels_.count(type)) {
      Instantiate(name, type, spec, where, env, depth);
      return;
    }
    const auto kind = ParseKind(type);
    if (!kind) {
      std::vector<std::string> names = {"Se", "Sf", "I", "C", "R", "TF", "MTF", "GY", "MGY", "0", "1"};
      for (const auto& [sm, def] : submodels_) names.push_back(sm);
      const std::string guess = DidYouMean(type, names);
      sink_.Error(Loc(spec["type"]), name, fmt::format("unknown element type '{}'", type),
                  guess.empty() ? "use Se, Sf, I, C, R, TF, MTF, GY, MGY, 0, 1 or a submodel name" : fmt::format("did you mean '{}'?", guess));
      return;
    }
    Element e;
    e.name = name;
    e.kind = *kind;
    e.where = where;
    std::vector<std::string> keys = kCommonKeys;
    if (IsTwoPort(e.kind)) keys = {"type", "description"};  // dimensions come from the ratio; domains may differ per port
    auto require = [&](const char* key, const char* hint) {
      if (spec[key]) return true;
      sink_.Error(where, name, fmt::format("{} needs '{}'", KindName(e.kind), key), hint);
      return false;
    };
    switch (e.kind) {
      case ElementKind::kSe:
      case ElementKind::kSf: {
        const char* key = e.kind == ElementKind::kSe ? "effort" : "flow";
        keys.push_back(key);
        if (e.kind == ElementKind::kSf) {
          keys.insert(keys.end(), {"constraint", "compliance"});
          if (spec["constraint"]) e.constraint = Bool(spec["constraint"], name);
          if (spec["compliance"]) {
            if (!e.constraint)
              sink_.Error(Loc(spec["compliance"]), name, "'compliance' belongs to an ideal constraint",
                          "add 'constraint: true', or model the coupling as a C");
            e.compliance = Vector(spec["compliance"], name, env);
            for (Eigen::Index k = 0; k < e.compliance.size(); ++k)
              if (!(e.compliance[k] > 0) || !std::isfinite(e.compliance[k]))
                sink_.Error("param.range", Loc(spec["compliance"]), name,
                            fmt::format("compliance must be > 0 and finite (got {:g})", e.compliance[k]),
                            "the compliance 1/K of the coupling the constraint stands for shares a redundant reaction");
          }
        }
        if (require(key, e.kind == ElementKind::kSe ? "e.g. effort: 1.0 or effort: {step: 1.0}" : "e.g. flow: 0 or flow: {sine: {amplitude: 1, frequency: 2}}"))
          e.source = ReadSource(spec[key], name, env);
        break;
      }
      case ElementKind::kI:
        keys.insert(keys.end(), {"inertia", "p0", "rotation"});
        if (require("inertia", "e.g. inertia: 2.0 (kg, kg m^2, H, ...)")) e.param = ReadParam(spec["inertia"], name, env);
        if (spec["p0"]) e.initial = Vector(spec["p0"], name, env);
        if (spec["rotation"]) e.rotation = Qualify(prefix, Str(spec["rotation"], name));
        break;
      case ElementKind::kC:
        keys.insert(keys.end(), {"stiffness", "compliance", "q0"});
        if (spec["stiffness"] && spec["compliance"]) sink_.Error(where, name, "give either 'stiffness' or 'compliance', not both");
        if (spec["compliance"]) {
          Param c = ReadParam(spec["compliance"], name, env);
          // The stiffness is its inverse; a bad compliance is said once, here, and leaves a stiffness of 1.
          if (c.is_scalar) {
            const bool ok = c.scalar > 0;
            if (!ok)
              sink_.Error("param.range", Loc(spec["compliance"]), name, fmt::format("compliance must be > 0 (got {:g})", c.scalar),
                          "a compliance stores energy only when positive");
            e.param = Param::Scalar(ok ? 1.0 / c.scalar : 1.0);
          } else {
            const bool ok = c.matrix.allFinite() && IsPositiveDefinite(c.matrix);
            if (!ok && c.matrix.size() > 0)
              sink_.Error("param.range", Loc(spec["compliance"]), name, "compliance matrix must be symmetric positive definite",
                          "a compliance stores energy in every direction only when positive definite (a singular one "
                          "has no stiffness: an ideal constraint is an Sf with constraint: true)");
            const bool square = c.matrix.rows() == c.matrix.cols();
            e.param = ok ? Param::Matrix(c.matrix.inverse())
                         : square ? Param::Matrix(Eigen::MatrixXd::Identity(c.matrix.rows(), c.matrix.cols())) : c;
          }
        } else if (require("stiffness", "e.g. stiffness: 100 (N/m, N m/rad, 1/F, ...)")) {
          e.param = ReadParam(spec["stiffness"], name, env);
        }
        if (spec["q0"]) e.initial = Vector(spec["q0"], name, env);
        break;
      case ElementKind::kR:
        keys.push_back("resistance");
        if (require("resistance", "e.g. resistance: 2.0 (N s/m, N m s/rad, ohm, ...)")) e.param = ReadParam(spec["resistance"], name, env);
        break;
      case ElementKind::kTF:
      case ElementKind::kGY:
        keys.push_back("ratio");
        if (require("ratio", "e.g. ratio: 0.25, or a matrix (rows = port 2, columns = port 1)")) {
          e.param = ReadParam(spec["ratio"], name, env);
          if (e.param.is_scalar && e.param.scalar == 0.0) sink_.Error(Loc(spec["ratio"]), name, "ratio must not be 0");
        }
        break;
      case ElementKind::kMTF:
      case ElementKind::kMGY:
        keys.push_back("modulus");
        if (require("modulus", "e.g. modulus: {rotation: A.R, transpose: true}")) e.modulus = ReadModulus(spec["modulus"], name, prefix, env);
        break;
      case ElementKind::kZero:
      case ElementKind::kOne:
        break;
    }
    CheckKeys(spec, keys, name);
    if (spec["dim"]) {
      const double d = Number(spec["dim"], name, env);
      if (d < 1 || d > 64 || d != std::floor(d)) sink_.Error(Loc(spec["dim"]), name, fmt::format("dim must be a whole number from 1 to 64 (got {:g})", d));
      else e.dim = static_cast<int>(d);
    }
    if (spec["domain"]) e.domain = Domain(spec["domain"], name);
    if (spec["components"])
      e.components = Components(spec["components"], name);
    if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
      sink_.Error(where, name, "duplicate name", "give every element and state a unique name");
      return;
    }
    graph_.Add(std::move(e));
  }

  void Instantiate(const std::string& name, const std::string& type, const YAML::Node& spec, const SourceLocation& where,
                   const Env& outer, int depth) {
    // A submodel that contains itself (directly or through others) would expand without end.
    if (std::find(instantiating_.begin(), instantiating_.end(), type) != instantiating_.end()) {
      std::string chain;
      for (const auto& t : instantiating_) chain += t + " -> ";
      sink_.Error("submodel.recursive", where, name, fmt::format("submodel '{}' contains itself: {}{}", type, chain, type),
                  "a submodel may use other submodels, but not itself");
      return;
    }
    instantiating_.push_back(type);
    InstantiateBody(name, type, spec, where, outer, depth);
    instantiating_.pop_back();
  }

  void InstantiateBody(const std::string& name, const std::string& type, const YAML::Node& spec, const SourceLocation& where,
                       const Env& outer, int depth) {
    const SubmodelDef& def = submodels_.at(type);
    if (++instances_ > limits_.instances) return;  // said by CheckExpansion before expanding
    Env env = def.defaults;
    std::vector<std::string> keys = {"type", "description"};
    for (const auto& [p, v] : def.defaults) keys.push_back(p);
    CheckKeys(spec, keys, name);
    for (const auto& kv : spec) {
      const std::string key = kv.first.Scalar();
      if (key != "type" && key != "description" && def.defaults.count(key)) env[key] = Number(kv.second, name, outer);
    }
    if (!def.ports_in_error) instance_ports_[name] = def.ports;
    instance_where_[name] = where;
    ReadScope(def.node, name, env, depth + 1);
  }

  /// Resolves a bond end: a local name in this scope, or "instance.port" of a submodel instance.
  std::string Endpoint(const std::string& local, const std::string& prefix, const YAML::Node& at) {
    const std::string full = Qualify(prefix, local);
    const auto dot = full.rfind('.');
    if (dot != std::string::npos) {
      const std::string inst = full.substr(0, dot);
      const auto it = instance_ports_.find(inst);
      const bool inside = prefix == inst || prefix.rfind(inst + ".", 0) == 0;  // the instance's own bonds
      if (!inside && it != instance_ports_.end() && !it->second.count(full.substr(dot + 1)) && graph_.Find(full) >= 0) {
        std::string ports;
        for (const auto& p : it->second) ports += (ports.empty() ? "" : ", ") + p;
        sink_.Error(Loc(at), full, fmt::format("'{}' is not a port of submodel instance '{}'", full.substr(dot + 1), inst),
                    ports.empty() ? "the submodel exposes no ports" : "its ports are: " + ports);
      }
    }
    return full;
  }

  void ReadBond(const YAML::Node& b, const std::string& prefix, const Env& env) {
    std::string from, to, name;
    int dim = 0;
    if (b.IsScalar()) {
      const std::string s = b.Scalar();
      const auto arrow = s.find("->");
      if (arrow == std::string::npos) {
        sink_.Error(Loc(b), s, "a bond is written 'from -> to'", "e.g. '- force -> j1' (the half-arrow points to 'to')");
        return;
      }
      auto trim = [](std::string x) {
        const auto a = x.find_first_not_of(" \t"), z = x.find_last_not_of(" \t");
        return a == std::string::npos ? std::string() : x.substr(a, z - a + 1);
      };
      from = trim(s.substr(0, arrow));
      to = trim(s.substr(arrow + 2));
      if (from.empty() || to.empty()) {
        sink_.Error(Loc(b), s, fmt::format("the bond has no '{}' end", from.empty() ? "from" : "to"),
                    "write it 'from -> to', e.g. '- force -> j1'");
        return;
      }
    } else if (b.IsSequence() && b.size() == 2) {
      from = b[0].Scalar();
      to = b[1].Scalar();
    } else if (b.IsMap()) {
      CheckKeys(b, {"from", "to", "name", "dim"}, "bond");
      if (!b["from"] || !b["to"]) {
        sink_.Error(Loc(b), "bond", "a bond needs 'from' and 'to'");
        return;
      }
      from = b["from"].Scalar();
      to = b["to"].Scalar();
      if (b["name"]) {
        if (!CheckName(b["name"].Scalar(), Loc(b["name"]), "a bond's")) return;
        name = Qualify(prefix, b["name"].Scalar());
        // Its variables (name.e, name.f) must name one thing: not another bond, not an element.
        if (const auto it = bond_names_.find(name); it != bond_names_.end()) {
          Diagnostic d;
          d.where = Loc(b["name"]);
          d.element = name;
          d.code = "name.duplicate";
          d.message = "duplicate bond name";
          d.details.push_back("first given at " + it->second.ToString());
          d.hint = "give every named bond a unique name";
          sink_.Add(d);
          return;
        }
        if (graph_.Find(name) >= 0) {
          sink_.Error("name.duplicate", Loc(b["name"]), name, "a bond may not be named like an element",
                      "rename the bond: its variables would read like the element's");
          return;
        }
        bond_names_[name] = Loc(b["name"]);
      }
      if (b["dim"]) {
        const double d = Number(b["dim"], "bond", env);
        if (d < 1 || d > 64 || d != std::floor(d))
          sink_.Error("param.range", Loc(b["dim"]), "bond", fmt::format("dim must be a whole number from 1 to 64 (got {:g})", d));
        else
          dim = static_cast<int>(d);
      }
    } else {
      sink_.Error(Loc(b), "bond", "a bond is 'from -> to', [from, to] or {from: ..., to: ...}");
      return;
    }
    const std::string f = Endpoint(from, prefix, b), t = Endpoint(to, prefix, b);
    bool ok = true;
    for (const auto& [end, local] : {std::pair{f, from}, std::pair{t, to}}) {
      if (graph_.Find(end) >= 0) continue;
      ok = false;
      if (refused_elements_.count(end)) continue;
      std::vector<std::string> names;
      for (const auto& e : graph_.elements()) names.push_back(e.name);
      const std::string guess = DidYouMean(end, names);
      sink_.Error(Loc(b), end, "bond refers to an element that does not exist",
                  guess.empty() ? "define it under 'elements'" : fmt::format("did you mean '{}'?", guess));
    }
    if (!ok) return;
    if (f == t) {
      sink_.Error(Loc(b), f, "bond connects an element to itself");
      return;
    }
    graph_.Connect(f, t, dim, name, Loc(b));
  }

  void ReadStates(const YAML::Node& n, const std::string& prefix, const Env& env) {
    if (!n.IsMap()) {
      sink_.Error(Loc(n), "states", "'states' must be a mapping of names to {kind: orientation|integral, of: ...}");
      return;
    }
    for (const auto& kv : n) {
      const std::string name = Qualify(prefix, kv.first.Scalar());
      const YAML::Node s = kv.second;
      if (!CheckName(kv.first.Scalar(), Loc(kv.first), "a state's")) continue;
      AuxState a;
      a.name = name;
      a.where = Loc(kv.first);
      if (!s.IsMap()) {
        sink_.Error(a.where, name, "a state is a mapping {kind: ..., of: ...}");
        continue;
      }
      CheckKeys(s, {"kind", "of", "initial", "components", "unit", "description"}, name);
      const std::string kind = s["kind"] ? s["kind"].Scalar() : "";
      if (kind == "orientation") a.kind = AuxState::Kind::kOrientation;
      else if (kind == "integral") a.kind = AuxState::Kind::kIntegral;
      else {
        const std::string guess = DidYouMean(kind, {"orientation", "integral"});
        sink_.Error(s["kind"] ? Loc(s["kind"]) : a.where, name, fmt::format("unknown state kind '{}'", kind),
                    guess.empty() ? "use kind: orientation or kind: integral" : fmt::format("did you mean '{}'?", guess));
        continue;
      }
      if (!s["of"]) {
        sink_.Error(a.where, name, "state needs 'of': the 1-junction or one-port whose flow it integrates");
        continue;
      }
      a.of = Qualify(prefix, s["of"].Scalar());
      if (s["initial"]) {
        if (a.kind == AuxState::Kind::kOrientation) {
          a.initial = Matrix(s["initial"], name, env);
          if (a.initial.rows() != 3 || a.initial.cols() != 3) sink_.Error(Loc(s["initial"]), name, "an orientation's initial value is a 3x3 matrix");
          else if (!(a.initial.transpose() * a.initial).isApprox(Eigen::Matrix3d::Identity(), 1e-9) || a.initial.determinant() < 0)
            sink_.Error(Loc(s["initial"]), name, "the initial orientation is not a rotation matrix (R^T R = I, det R = +1)");
        } else {
          a.initial = Vector(s["initial"], name, env);
        }
      }
      if (s["components"])
        a.components = Components(s["components"], name);
      if (s["unit"]) {
        // A unit labels columns and reaches gnuplot scripts and HTML: only the unit grammar passes.
        a.unit = Str(s["unit"], name);
        if (const std::string problem = UnitProblem(a.unit); !problem.empty()) {
          sink_.Error("unit.invalid", Loc(s["unit"]), name, fmt::format("the unit '{}' is refused: {}", PrintableExcerpt(a.unit), problem),
                      "write SI symbols with an optional prefix, separated by spaces or '*', one '/', whole exponents: "
                      "e.g. m, rad, N m, kg m^2, rad/s, m s^-2; '-' for none");
          a.unit.clear();
        }
      }
      if (graph_.Find(name) >= 0 || graph_.FindAux(name) >= 0) {
        sink_.Error(a.where, name, "duplicate name", "give every element and state a unique name");
        continue;
      }
      graph_.AddAux(std::move(a));
    }
  }

  void ReadOutputs(const YAML::Node& n) {
    if (!n.IsSequence()) {
      sink_.Error(Loc(n), "outputs", "'outputs' must be a list", "e.g. '- spring.e' or '- {name: position, variable: spring.q}'");
      return;
    }
    for (const auto& o : n) {
      OutputDecl d;
      d.where = Loc(o);
      if (o.IsScalar()) {
        d.name = d.variable = o.Scalar();
      } else if (o.IsMap()) {
        CheckKeys(o, {"name", "variable"}, "output");
        if (!o["variable"]) {
          sink_.Error(d.where, "output", "an output needs 'variable'");
          continue;
        }
        d.variable = o["variable"].Scalar();
        d.name = o["name"] ? o["name"].Scalar() : d.variable;
        if (o["name"] && !CheckName(d.name, Loc(o["name"]), "an output's")) continue;
      } else {
        sink_.Error(d.where, "output", "an output is a variable name or {name: ..., variable: ...}");
        continue;
      }
      graph_.AddOutput(d);
    }
  }

  /// `mechanism`: the model has bodies (joint coordinates need them).
  void ReadSimulation(const YAML::Node& n, SimulationDefaults& s, bool mechanism) {
    if (!n.IsMap()) {
      sink_.Error(Loc(n), "simulation", "'simulation' is a mapping of settings", "write e.g. simulation: {t_end: 5, dt: 0.001}");
      return;
    }
    CheckKeys(n, {"t_end", "dt", "solver", "rtol", "atol", "step", "max_step", "coordinates"}, "simulation");
    const Env none;
    auto positive = [&](const char* key, std::optional<double>& out) {
      if (!n[key]) return;
      bool ok = true;
      const double v = Number(n[key], "simulation", none, &ok);
      if (!ok) return;  // said by Number
      if (!(v > 0)) sink_.Error(Loc(n[key]), "simulation", fmt::format("{} must be > 0 (got {:g})", key, v));
      out = v;
    };
    positive("t_end", s.t_end);
    positive("dt", s.dt);
    positive("rtol", s.rtol);
    positive("atol", s.atol);
    positive("step", s.step);
    positive("max_step", s.max_step);
    // What the run would refuse of these settings is an error of the file, here, not at 'run'.
    auto check_together = [&](const char* key, auto&& check) {
      try {
        check();
      } catch (const std::invalid_argument& e) {
        sink_.Error(Loc(n[key]), "simulation", e.what());
      }
    };
    if (s.rtol && *s.rtol > 0) check_together("rtol", [&] { CheckRelativeTolerance(*s.rtol); });
    if (s.t_end && s.dt && *s.t_end > 0 && *s.dt > 0) check_together("dt", [&] { CheckOutputGrid(0.0, *s.t_end, *s.dt); });
    if (s.step && s.dt) check_together("step", [&] { CheckFixedStep(*s.step, *s.dt); });
    if (const YAML::Node c = n["coordinates"]) {
      if (!c.IsScalar() || (c.Scalar() != "joint" && c.Scalar() != "inertial"))
        sink_.Error(Loc(c), "simulation", "'coordinates' is joint or inertial",
                    "joint: the integrator advances each body relative to its tree joint; inertial: the model's own states");
      else if (c.Scalar() == "joint" && !mechanism)
        sink_.Error(Loc(c), "simulation", "joint coordinates are for mechanisms: the model has no bodies", "remove 'coordinates'");
      else
        s.coordinates = c.Scalar();
    }
    if (n["solver"]) {
      s.solver = n["solver"].Scalar();
      try {
        const Method method = ParseMethod(*s.solver);
        if (method == Method::kRk4 && !s.step)
          sink_.Error(Loc(n["solver"]), "simulation", "rk4 is a fixed-step method and needs 'step'", "add step: 1.0e-4 (or use dopri5)");
        if (UsesNewtonMatrix(method) && s.step)
          sink_.Error(Loc(n["step"]), "simulation", fmt::format("{} chooses its own steps: a fixed 'step' is for {}", *s.solver, kFixedStepMethodNames),
                      "bound its steps with max_step instead");
      } catch (const std::invalid_argument& e) {
        sink_.Error(Loc(n["solver"]), "simulation", e.what());
      }
    }
  }


  // --- mechanism sections: bodies, joints, gears, drives, points (docs/mechanisms.md) --------

  Eigen::Vector3d Vec3(const YAML::Node& n, const std::string& element) {
    const Eigen::VectorXd v = Vector(n, element, Env{});
    if (v.size() != 3) {
      sink_.Error(Loc(n), element, fmt::format("expected 3 numbers, got {}", v.size()), "write e.g. [0, 0, 1]");
      return Eigen::Vector3d::Zero();
    }
    return v;
  }

  /// "x", "-z" or a 3-vector (normalised).
  Eigen::Vector3d Axis(const YAML::Node& n, const std::string& element) {
    if (n.IsScalar()) {
      std::string s = n.Scalar();
      double sign = 1.0;
      if (!s.empty() && (s[0] == '-' || s[0] == '+')) {
        sign = s[0] == '-' ? -1.0 : 1.0;
        s = s.substr(1);
      }
      if (s == "x") return sign * Eigen::Vector3d::UnitX();
      if (s == "y") return sign * Eigen::Vector3d::UnitY();
      if (s == "z") return sign * Eigen::Vector3d::UnitZ();
      sink_.Error(Loc(n), element, fmt::format("unknown axis '{}'", n.Scalar()), "write x, y, z, -x, ... or a vector [ax, ay, az]");
      return Eigen::Vector3d::UnitX();
    }
    const Eigen::Vector3d v = Vec3(n, element);
    if (v.norm() < 1e-12) {
      sink_.Error(Loc(n), element, "an axis must be a non-zero vector");
      return Eigen::Vector3d::UnitX();
    }
    return v.normalized();
  }

  /// Rows of unit vectors: "all", a list of axes, or a matrix.
  Eigen::MatrixXd Directions(const YAML::Node& n, const std::string& element, std::vector<std::string>* names) {
    if (n.IsScalar() && n.Scalar() == "all") {
      *names = {"x", "y", "z"};
      return Eigen::Matrix3d::Identity();
    }
    if (!n.IsSequence() || n.size() == 0 || n.size() > 3) {
      sink_.Error(Loc(n), element, "directions are 'all' or a list of 1 to 3 axes", "write e.g. axes: [y, z]");
      return Eigen::Matrix3d::Identity();
    }
    Eigen::MatrixXd rows(static_cast<Eigen::Index>(n.size()), 3);
    bool named = true;
    for (size_t i = 0; i < n.size(); ++i) {
      rows.row(static_cast<Eigen::Index>(i)) = Axis(n[i], element).transpose();
      named = named && n[i].IsScalar();
      if (n[i].IsScalar()) names->push_back(n[i].Scalar()[0] == '-' ? n[i].Scalar().substr(1) : n[i].Scalar());
    }
    if (!named) names->clear();
    return rows;
  }

  Eigen::Matrix3d Orientation(const YAML::Node& n, const std::string& element) {
    if (n.IsMap()) {
      CheckKeys(n, {"axis", "angle", "degrees"}, element);
      if (!n["axis"] || (!n["angle"] && !n["degrees"])) {
        sink_.Error(Loc(n), element, "an orientation is a 3x3 matrix or {axis: ..., angle: radians | degrees: ...}");
        return Eigen::Matrix3d::Identity();
      }
      const double angle = n["angle"] ? Number(n["angle"], element, Env{}) : Number(n["degrees"], element, Env{}) * std::numbers::pi / 180.0;
      return Eigen::AngleAxisd(angle, Axis(n["axis"], element)).toRotationMatrix();
    }
    const Eigen::MatrixXd m = Matrix(n, element, Env{});
    if (m.rows() != 3 || m.cols() != 3) {
      sink_.Error(Loc(n), element, "an orientation matrix is 3x3");
      return Eigen::Matrix3d::Identity();
    }
    return m;
  }

  /// K (required unless `rigid`) and R of a coupling, one value or one per direction.
  void Gains(const YAML::Node& n, const std::string& element, int k, Eigen::VectorXd* stiff, Eigen::VectorXd* damp,
             bool rigid = false) {
    auto read = [&](const char* a, const char* b, Eigen::VectorXd* out, bool required) {
      const YAML::Node v = n[a] ? n[a] : n[b];
      if (!v) {
        if (required) sink_.Error(Loc(n), element, fmt::format("coupling needs '{}' (or '{}')", a, b), "e.g. {K: 1.0e6, R: 20}");
        *out = Eigen::VectorXd::Zero(k);
        return;
      }
      const Eigen::VectorXd x = Vector(v, element, Env{});
      if (x.size() == 1) *out = Eigen::VectorXd::Constant(k, x[0]);
      else if (x.size() == k) *out = x;
      else {
        sink_.Error(Loc(v), element, fmt::format("give one value or {} (one per direction), got {}", k, x.size()));
        *out = Eigen::VectorXd::Constant(k, 1.0);
      }
    };
    read("K", "stiffness", stiff, !rigid);
    read("R", "damping", damp, false);
  }

  mech::Coupling::Frame Frame(const YAML::Node& n, const std::string& element, mech::Coupling::Frame dflt) {
    if (!n) return dflt;
    const std::string f = n.Scalar();
    if (f == "world") return mech::Coupling::Frame::kWorld;
    if (f == "parent") return mech::Coupling::Frame::kParent;
    if (f == "child") return mech::Coupling::Frame::kChild;
    sink_.Error(Loc(n), element, fmt::format("unknown frame '{}'", f), "use world, parent or child");
    return dflt;
  }

  /// A coupling section: {K, R, directions|axes, frame}. `fixed_rows` (named kinds) gives the
  /// directions; otherwise they are read (default: all three).
  std::optional<mech::Coupling> ReadCoupling(const YAML::Node& n, const std::string& element, const char* what,
                                             const Eigen::MatrixXd* fixed_rows, mech::Coupling::Frame frame) {
    if (!n) return std::nullopt;
    if (!n.IsMap()) {
      sink_.Error(Loc(n), element, fmt::format("'{}' is a mapping like {{K: 1.0e6, R: 20}}", what));
      return std::nullopt;
    }
    mech::Coupling c;
    std::vector<std::string> keys = {"K", "R", "stiffness", "damping", "rigid"};
    if (!fixed_rows) keys.insert(keys.end(), {"directions", "axes", "frame"});
    CheckKeys(n, keys, element);
    if (fixed_rows) {
      c.directions = *fixed_rows;
    } else {
      const YAML::Node d = n["directions"] ? n["directions"] : n["axes"];
      c.directions = d ? Directions(d, element, &c.components) : Eigen::MatrixXd(Eigen::Matrix3d::Identity());
      if (!d) c.components = {"x", "y", "z"};
      frame = Frame(n["frame"], element, frame);
    }
    if (fixed_rows && c.directions.rows() == 3 && c.directions.cols() == 3 && c.directions == Eigen::MatrixXd::Identity(3, 3))
      c.components = {"x", "y", "z"};
    c.frame = frame;
    c.rigid = (n["rigid"] && Bool(n["rigid"], element)) || rigid_joint_;
    // A rigid coupling's K and R, if given, are the compliant variant's: R is unused, K only
    // decides how redundant constraints share a load (CompiledModel::ShareRedundantEfforts).
    Gains(n, element, static_cast<int>(c.directions.rows()), &c.stiffness, &c.damping, c.rigid);
    if (c.rigid) c.damping = Eigen::VectorXd::Zero(c.directions.rows());
    return c;
  }

  mech::MassProperties Mass(const YAML::Node& b, const std::string& name) {
    if (b["shape"]) {
      const YAML::Node sh = b["shape"];
      for (const char* key : {"mass", "inertia"})
        if (b[key])
          sink_.Error(Loc(b[key]), name, fmt::format("a body with a shape takes its {} from the shape and density", key),
                      fmt::format("give either shape and density, or mass and inertia: remove '{}' or 'shape'", key));
      if (!b["density"]) sink_.Error(Loc(sh), name, "a shape needs a 'density' [kg/m^3]");
      const double rho = b["density"] ? Number(b["density"], name, Env{}) : 1.0;
      if (!(rho > 0)) sink_.Error("param.range", Loc(b["density"]), name, fmt::format("density must be > 0 (got {:g})", rho));
      if (!sh.IsMap() || sh.size() != 1) {
        sink_.Error(Loc(sh), name, "shape is one of {disc: ...}, {cylinder: ...}, {box: ...}, {sphere: ...}");
        return mech::MassProperties::PointMass(1.0);
      }
      const std::string kind = sh.begin()->first.Scalar();
      const YAML::Node p = sh.begin()->second;
      if (!p.IsMap()) {
        sink_.Error(Loc(p), name, fmt::format("the {} needs its dimensions as a mapping", kind),
                    "write e.g. shape: {disc: {diameter: 0.1, thickness: 0.01, axis: z}}");
        return mech::MassProperties::PointMass(1.0);
      }
      auto num = [&](const char* key) {
        if (!p[key]) {
          sink_.Error(Loc(p), name, fmt::format("{} needs '{}'", kind, key));
          return 1.0;
        }
        const double v = Number(p[key], name, Env{});
        if (!(v > 0)) sink_.Error("param.range", Loc(p[key]), name, fmt::format("{} must be > 0 (got {:g})", key, v));
        return v;
      };
      auto axis_index = [&]() {
        if (!p["axis"]) return 2;
        const Eigen::Vector3d a = Axis(p["axis"], name);
        int k = 0;
        for (int i = 1; i < 3; ++i)
          if (std::abs(a[i]) > std::abs(a[k])) k = i;
        if (std::abs(std::abs(a[k]) - 1.0) > 1e-12) sink_.Error(Loc(p["axis"]), name, "a shape's axis is x, y or z");
        return k;
      };
      if (kind == "disc" || kind == "cylinder") {
        CheckKeys(p, {"diameter", "thickness", "length", "axis"}, name);
        const double len = kind == "disc" ? num("thickness") : num("length");
        return mech::MassProperties::Cylinder(rho, num("diameter"), len, axis_index());
      }
      if (kind == "box") {
        CheckKeys(p, {"size"}, name);
        return mech::MassProperties::Box(rho, p["size"] ? Vec3(p["size"], name) : Eigen::Vector3d::Ones());
      }
      if (kind == "sphere") {
        CheckKeys(p, {"diameter"}, name);
        return mech::MassProperties::Sphere(rho, num("diameter"));
      }
      const std::string guess = DidYouMean(kind, {"disc", "cylinder", "box", "sphere"});
      sink_.Error(Loc(sh.begin()->first), name, fmt::format("unknown shape '{}'", kind),
                  guess.empty() ? "use disc, cylinder, box or sphere" : fmt::format("did you mean '{}'?", guess));
      return mech::MassProperties::PointMass(1.0);
    }
    if (!b["mass"]) {
      sink_.Error(Loc(b), name, "a body needs a 'shape' and 'density', or a 'mass' (and 'inertia')");
      return mech::MassProperties::PointMass(1.0);
    }
    const double m = Number(b["mass"], name, Env{});
    if (!b["inertia"]) return mech::MassProperties::PointMass(m);
    const Param ip = ReadParam(b["inertia"], name, Env{});
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();
    if (ip.is_scalar) inertia *= ip.scalar;
    else if (ip.matrix.rows() == 3 && ip.matrix.cols() == 3) inertia = ip.matrix;
    else sink_.Error(Loc(b["inertia"]), name, "inertia is a number, 3 principal moments or a 3x3 matrix");
    // A zero tensor would make a point mass and drop the body's rotation (and its omega columns) silently.
    if (inertia.isZero(0.0))
      sink_.Error("param.range", Loc(b["inertia"]), name, "inertia must be positive definite (got 0)", "leave 'inertia' out for a point mass");
    return mech::MassProperties::Given(m, inertia);
  }

  /// The model's 'rigid' key: 'all' (every joint and gear mesh) or a list of their names.
  bool RigidByModel(const std::string& name) const {
    if (rigid_all_) return true;
    return std::find(rigid_names_.begin(), rigid_names_.end(), name) != rigid_names_.end();
  }

  void ReadMechanism(const YAML::Node& root) {
    if (const YAML::Node r = root["rigid"]) {
      if (r.IsScalar() && (r.Scalar() == "all" || r.Scalar() == "true")) {
        rigid_all_ = true;
      } else if (r.IsSequence()) {
        for (const auto& n : r) {
          rigid_names_.push_back(n.Scalar());
          rigid_where_.push_back(Loc(n));
        }
      } else {
        sink_.Error(Loc(r), "rigid", "'rigid' is 'all' or a list of joint and gear mesh names",
                    "write e.g. 'rigid: all' or 'rigid: [G_bearing, mesh_GA]'");
      }
    }
    mech::Mechanism m;
    if (root["gravity"]) m.SetGravity(Vec3(root["gravity"], "gravity"));
    const YAML::Node bodies = root["bodies"];
    if (!bodies.IsMap()) {
      sink_.Error(Loc(bodies), "bodies", "'bodies' is a mapping of names to bodies");
      return;
    }
    // Positions may be given relative to another body: resolve in dependency order.
    std::map<std::string, YAML::Node> spec;
    std::vector<std::string> order;
    for (const auto& kv : bodies) {
      if (!CheckName(kv.first.Scalar(), Loc(kv.first), "a body's")) continue;
      spec[kv.first.Scalar()] = kv.second;
      order.push_back(kv.first.Scalar());
    }
    std::map<std::string, mech::Body> made;
    std::set<std::string> in_progress;
    std::function<const mech::Body*(const std::string&, const YAML::Node&)> make = [&](const std::string& name,
                                                                                       const YAML::Node& at) -> const mech::Body* {
      if (made.count(name)) return &made[name];
      if (!spec.count(name)) {
        sink_.Error("mech.reference", Loc(at), name, fmt::format("no body called '{}'", name), "define it under 'bodies'");
        return nullptr;
      }
      if (in_progress.count(name)) {
        sink_.Error("mech.reference", Loc(at), name, "body positions refer to each other in a circle");
        return nullptr;
      }
      in_progress.insert(name);
      const YAML::Node b = spec[name];
      mech::Body body;
      body.name = name;
      body.where = Loc(b);
      if (!b.IsMap()) {
        sink_.Error(Loc(b), name, "a body is a mapping with shape/density or mass/inertia, position, ...");
        made[name] = body;
        return &made[name];
      }
      CheckKeys(b, {"shape", "density", "mass", "inertia", "position", "orientation", "velocity", "omega", "description"}, name);
      body.mass = Mass(b, name);
      if (b["orientation"]) body.orientation = Orientation(b["orientation"], name);
      if (const YAML::Node p = b["position"]) {
        if (p.IsMap()) {
          CheckKeys(p, {"relative_to", "offset"}, name);
          const mech::Body* ref = p["relative_to"] ? make(p["relative_to"].Scalar(), p["relative_to"]) : nullptr;
          const Eigen::Vector3d off = p["offset"] ? Vec3(p["offset"], name) : Eigen::Vector3d::Zero();
          if (ref) body.position = ref->position + ref->orientation * off;
          else if (!p["relative_to"]) sink_.Error(Loc(p), name, "a relative position needs 'relative_to' (a body) and 'offset' (in its frame)");
        } else {
          body.position = Vec3(p, name);
        }
      }
      if (b["velocity"]) body.velocity = Vec3(b["velocity"], name);
      if (b["omega"]) body.omega = Vec3(b["omega"], name);
      in_progress.erase(name);
      made[name] = body;
      return &made[name];
    };
    for (const std::string& name : order) {
      make(name, spec[name]);
      m.AddBody(made[name]);
    }
    auto body_or_ground = [&](const std::string& n) -> const mech::Body* { return made.count(n) ? &made[n] : nullptr; };

    if (const YAML::Node joints = root["joints"]) {
      for (const auto& kv : joints) {
        const std::string name = kv.first.Scalar();
        const YAML::Node j = kv.second;
        if (!CheckName(name, Loc(kv.first), "a joint's")) continue;
        mech::Joint joint;
        joint.name = name;
        joint.where = Loc(kv.first);
        if (!j.IsMap()) {
          sink_.Error(joint.where, name, "a joint is a mapping with type, parent, child, ...");
          continue;
        }
        const std::string type = j["type"] ? j["type"].Scalar() : "coupling";
        const std::vector<std::string> types = {"coupling", "revolute", "fixed", "weld", "spherical", "prismatic", "held"};
        if (std::find(types.begin(), types.end(), type) == types.end()) {
          const std::string guess = DidYouMean(type, types);
          sink_.Error(Loc(j["type"]), name, fmt::format("unknown joint type '{}'", type),
                      guess.empty() ? "use coupling, revolute, fixed, spherical, prismatic or held" : fmt::format("did you mean '{}'?", guess));
          continue;
        }
        CheckKeys(j, {"type", "parent", "child", "at", "child_at", "axis", "translation", "rotation", "rigid", "description"}, name);
        // 'rigid: true' on the joint (or the model's 'rigid: all' / list) makes each of its
        // couplings an ideal constraint; the named kinds then need no coupling sections.
        rigid_joint_ = (j["rigid"] && Bool(j["rigid"], name)) || RigidByModel(name);
        const YAML::Node rigid_section = YAML::Load("{rigid: true}");
        joint.kind = type;
        joint.parent = j["parent"] ? j["parent"].Scalar() : std::string(mech::kGround);
        if (type == "held" && joint.parent != mech::kGround) sink_.Error(Loc(j["parent"]), name, "a 'held' joint holds its child to the ground", "remove 'parent'");
        if (!j["child"]) {
          sink_.Error(joint.where, name, "a joint needs a 'child' body");
          continue;
        }
        joint.child = j["child"].Scalar();
        if (j["child_at"]) joint.child_point = Vec3(j["child_at"], name);
        const mech::Body* parent = body_or_ground(joint.parent);
        const mech::Body* child = body_or_ground(joint.child);
        if (j["at"]) {
          joint.parent_point = Vec3(j["at"], name);
        } else if (child && (parent || joint.parent == mech::kGround)) {
          // By default the joint sits where the child's attachment is at t = 0: undeflected.
          const Eigen::Vector3d p = child->position + child->orientation * joint.child_point;
          joint.parent_point = parent ? Eigen::Vector3d(parent->orientation.transpose() * (p - parent->position)) : p;
        }
        const bool needs_axis = type == "revolute" || type == "prismatic";
        if (needs_axis && !j["axis"]) sink_.Error(joint.where, name, fmt::format("a {} joint needs an 'axis' (in the parent's frame)", type));
        const Eigen::Vector3d axis = j["axis"] ? Axis(j["axis"], name) : Eigen::Vector3d::UnitZ();
        const Eigen::MatrixXd all = Eigen::Matrix3d::Identity();
        const Eigen::MatrixXd perp = mech::Perpendicular(axis);
        using F = mech::Coupling::Frame;
        if (type == "coupling") {
          joint.translation = ReadCoupling(j["translation"], name, "translation", nullptr, F::kWorld);
          joint.rotation = ReadCoupling(j["rotation"], name, "rotation", nullptr, F::kParent);
        } else {
          const bool trans = type != "prismatic", rot_all = type == "fixed" || type == "weld" || type == "held" || type == "prismatic";
          if (j["translation"] || rigid_joint_)
            joint.translation = ReadCoupling(j["translation"] ? j["translation"] : rigid_section, name, "translation",
                                             trans ? &all : &perp, trans ? F::kWorld : F::kParent);
          else sink_.Error(joint.where, name, fmt::format("a {} joint needs 'translation: {{K: ..., R: ...}}' (or 'rigid: true')", type));
          if (type != "spherical") {
            if (j["rotation"] || rigid_joint_)
              joint.rotation = ReadCoupling(j["rotation"] ? j["rotation"] : rigid_section, name, "rotation", rot_all ? &all : &perp, F::kParent);
            else sink_.Error(joint.where, name, fmt::format("a {} joint needs 'rotation: {{K: ..., R: ...}}' (or 'rigid: true')", type));
          } else if (j["rotation"]) {
            sink_.Error(Loc(j["rotation"]), name, "a spherical joint leaves every rotation free", "remove 'rotation', or use type: coupling");
          }
        }
        rigid_joint_ = false;
        m.AddJoint(joint);
      }
    }
    if (const YAML::Node gears = root["gears"]) {
      for (const auto& kv : gears) {
        const std::string name = kv.first.Scalar();
        const YAML::Node g = kv.second;
        if (!CheckName(name, Loc(kv.first), "a gear mesh's")) continue;
        mech::GearMesh gm;
        gm.name = name;
        gm.where = Loc(kv.first);
        CheckKeys(g, {"carrier", "a", "b", "K", "R", "stiffness", "damping", "rigid", "description"}, name);
        gm.rigid = (g["rigid"] && Bool(g["rigid"], name)) || RigidByModel(name);
        gm.carrier = g["carrier"] ? g["carrier"].Scalar() : std::string(mech::kGround);
        auto side = [&](const char* key, std::string* body, Eigen::Vector3d* axis, double* teeth) {
          const YAML::Node s = g[key];
          if (!s || !s.IsMap()) {
            sink_.Error(gm.where, name, fmt::format("a gear mesh needs '{}: {{body: ..., axis: ..., teeth: ...}}'", key));
            return;
          }
          CheckKeys(s, {"body", "axis", "teeth"}, name);
          if (s["body"]) *body = s["body"].Scalar();
          else sink_.Error(Loc(s), name, fmt::format("gear '{}' needs a 'body'", key));
          if (s["axis"]) *axis = Axis(s["axis"], name);
          else sink_.Error(Loc(s), name, fmt::format("gear '{}' needs an 'axis' (in the carrier's frame)", key));
          if (s["teeth"]) *teeth = Number(s["teeth"], name, Env{});  // a whole number in range: mech::Mechanism
          else sink_.Error(Loc(s), name, fmt::format("gear '{}' needs 'teeth'", key));
        };
        side("a", &gm.body_a, &gm.axis_a, &gm.teeth_a);
        side("b", &gm.body_b, &gm.axis_b, &gm.teeth_b);
        {  // a rigid mesh uses K, if given, only to share a load with redundant constraints
          Eigen::VectorXd k, r;
          Gains(g, name, 1, &k, &r, gm.rigid);
          gm.stiffness = k[0];
          gm.damping = gm.rigid ? 0.0 : r[0];
        }
        m.AddGear(gm);
      }
    }
    if (const YAML::Node drives = root["drives"]) {
      for (const auto& kv : drives) {
        const std::string name = kv.first.Scalar();
        const YAML::Node d = kv.second;
        if (!CheckName(name, Loc(kv.first), "a drive's")) continue;
        mech::Drive drive;
        drive.name = name;
        drive.where = Loc(kv.first);
        const std::string type = d["type"] ? d["type"].Scalar() : "";
        const std::map<std::string, mech::Drive::Kind> kinds = {{"angular_velocity", mech::Drive::Kind::kAngularVelocity},
                                                                {"velocity", mech::Drive::Kind::kVelocity},
                                                                {"torque", mech::Drive::Kind::kTorque},
                                                                {"force", mech::Drive::Kind::kForce}};
        if (!kinds.count(type)) {
          sink_.Error(d["type"] ? Loc(d["type"]) : drive.where, name, fmt::format("unknown drive type '{}'", type),
                      "use angular_velocity, velocity, torque or force");
          continue;
        }
        drive.kind = kinds.at(type);
        const bool velocity = drive.kind == mech::Drive::Kind::kAngularVelocity || drive.kind == mech::Drive::Kind::kVelocity;
        std::vector<std::string> keys = {"type", "body", "axis", "value", "description"};
        if (velocity) keys.insert(keys.end(), {"reference", "K", "R", "stiffness", "damping"});
        if (drive.kind == mech::Drive::Kind::kForce) keys.push_back("at");
        CheckKeys(d, keys, name);
        if (d["body"]) drive.body = d["body"].Scalar();
        else sink_.Error(drive.where, name, "a drive needs a 'body'");
        if (d["reference"]) drive.reference = d["reference"].Scalar();
        if (d["axis"]) drive.axis = Axis(d["axis"], name);
        else sink_.Error(drive.where, name, "a drive needs an 'axis'");
        if (d["value"]) drive.value = ReadTimeFunction(d["value"], name, Env{});
        else sink_.Error(drive.where, name, "a drive needs a 'value' (a number or a time function)");
        if (d["at"]) drive.point = Vec3(d["at"], name);
        if (velocity) {
          Eigen::VectorXd k, r;
          Gains(d, name, 1, &k, &r);
          drive.stiffness = k[0];
          drive.damping = r[0];
        }
        m.AddDrive(drive);
      }
    }
    if (const YAML::Node points = root["points"]) {
      for (const auto& kv : points) {
        mech::Point p;
        p.name = kv.first.Scalar();
        p.where = Loc(kv.first);
        if (!CheckName(p.name, p.where, "a point's")) continue;
        CheckKeys(kv.second, {"body", "at", "description"}, p.name);
        if (kv.second["body"]) p.body = kv.second["body"].Scalar();
        else sink_.Error(p.where, p.name, "a point needs a 'body'");
        if (kv.second["at"]) p.at = Vec3(kv.second["at"], p.name);
        m.AddPoint(p);
      }
    }
    // Every name in 'rigid: [...]' must be a joint or a gear mesh (a misspelt one would leave
    // that part compliant without a word).
    std::vector<std::string> parts;
    for (const auto& j : m.joints()) parts.push_back(j.name);
    for (const auto& g : m.gears()) parts.push_back(g.name);
    for (size_t k = 0; k < rigid_names_.size(); ++k)
      if (std::find(parts.begin(), parts.end(), rigid_names_[k]) == parts.end()) {
        const std::string guess = DidYouMean(rigid_names_[k], parts);
        sink_.Error("mech.reference", rigid_where_[k], rigid_names_[k], "'rigid' names no joint or gear mesh of that name",
                    guess.empty() ? "list the joints and gear meshes to make rigid" : fmt::format("did you mean '{}'?", guess));
      }
    if (sink_.has_errors()) return;
    m.ExpandInto(graph_, sink_);
    mechanism_ = std::make_shared<mech::Mechanism>(std::move(m));
  }

  std::string file_, text_;
  const InputLimits& limits_;
  std::uint64_t instances_ = 0;  ///< submodel instances expanded so far
  std::shared_ptr<const mech::Mechanism> mechanism_;
  BondGraph graph_;
  DiagnosticSink sink_;
  bool rigid_joint_ = false;  ///< the joint being read is rigid (its couplings default to rigid)
  bool rigid_all_ = false;    ///< the model's 'rigid: all'
  std::vector<std::string> rigid_names_;  ///< the model's 'rigid: [names]' 
  std::map<std::string, SubmodelDef> submodels_;
  std::map<std::string, std::set<std::string>> instance_ports_;
  /// Elements the file defines but the loader refused (qualified names), with their error given.
  std::set<std::string> refused_elements_;
  std::map<std::string, SourceLocation> instance_where_;
  std::map<std::string, SourceLocation> bond_names_;  ///< the bonds named in the file, where
  std::vector<SourceLocation> rigid_where_;            ///< where each of rigid_names_ is written
  std::vector<std::string> instantiating_;  ///< the submodel types being expanded, outermost first
};

int EditDistance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (std::tolower(a[i - 1]) == std::tolower(b[j - 1]) ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

}  // namespace

std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  int best_d = 3;
  for (const auto& c : candidates) {
    const int d = EditDistance(word, c);
    if (d < best_d || (d == best_d && best.empty() && !word.empty() && c.rfind(word, 0) == 0)) {
      best_d = d;
      best = c;
    }
  }
  if (best.empty())
    for (const auto& c : candidates)
      if (word.size() >= 3 && c.rfind(word, 0) == 0) return c;
  return best_d <= std::max<int>(1, static_cast<int>(word.size()) / 3) || best_d <= 2 ? best : "";
}

void ExplainInMechanismTerms(const mech::Mechanism& m, std::vector<Diagnostic>& diagnostics) {
  for (Diagnostic& d : diagnostics) {
    if (d.code.rfind("causality.", 0) != 0 || d.details.empty()) continue;
    // The element names on the path are the quoted words of its first detail line.
    std::vector<std::string> parts;
    const std::string& path = d.details.front();
    for (size_t open = path.find('\''); open != std::string::npos;) {
      const size_t close = path.find('\'', open + 1);
      if (close == std::string::npos) break;
      std::string part = m.DescribePart(path.substr(open + 1, close - open - 1));
      if (part.empty()) part = fmt::format("'{}' (not a mechanism part)", path.substr(open + 1, close - open - 1));
      if (parts.empty() || parts.back() != part) parts.push_back(part);
      open = path.find('\'', close + 1);
    }
    bool any = false;
    for (const auto& p : parts) any = any || p.find("(not a mechanism part)") == std::string::npos;
    if (!any) continue;
    std::string line = "in mechanism terms: ";
    for (size_t i = 0; i < parts.size(); ++i) line += (i ? " -> " : "") + parts[i];
    d.details.push_back(line);
    if (d.code == "causality.derivative")
      d.details.push_back("the last part cannot move independently of the first: the connection between them has no "
                          "compliance; connect them through a joint, gear mesh or velocity drive (they carry K and R)");
  }
}

LoadedModel LoadModelString(const std::string& yaml, const std::string& file, const InputLimits& limits) {
  try {
    return Loader(file, yaml, limits).Load();
  } catch (const YAML::Exception& e) {
    // A node of a shape the loader did not expect somewhere it did not check: still a model
    // error, with the place yaml-cpp knows.
    Diagnostic d;
    d.where = {file, e.mark.line >= 0 ? e.mark.line + 1 : 0, e.mark.line >= 0 ? e.mark.column + 1 : 0};
    d.code = "yaml.structure";
    d.message = "unexpected structure in the model file (" + e.msg + ")";
    d.hint = "compare this part of the file with docs/model-format.md";
    throw ModelError(d);
  }
}

LoadedModel LoadModelFile(const std::string& path, const InputLimits& limits) {
  // O_NONBLOCK: opening a FIFO does not wait for a writer; it is refused below like a device.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0)
    ThrowIo(path, "io.unreadable", fmt::format("cannot open the model file: {}", std::strerror(errno)), "check the path and the file's permissions");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    ThrowIo(path, "io.unreadable", fmt::format("cannot read the model file: {}", std::strerror(errno)), "check the path and the file's permissions");
  if (!S_ISREG(st.st_mode)) {
    const char* kind = S_ISDIR(st.st_mode) ? "a directory" : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe)" : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device" : S_ISSOCK(st.st_mode) ? "a socket" : "not a regular file";
    ThrowIo(path, "io.not_regular", fmt::format("cannot read the model file: it is {}", kind), "give the path of a model file (.yaml)");
  }
  if (static_cast<std::uint64_t>(st.st_size) > limits.file_bytes) throw ModelError(FileSizeError(path, static_cast<std::uint64_t>(st.st_size), limits));
  // The file may grow while it is read: no more than the limit and one byte is read.
  std::string text;
  char buffer[1 << 16];
  while (text.size() <= limits.file_bytes) {
    const ssize_t n = ::read(fd, buffer, std::min<std::uint64_t>(sizeof buffer, limits.file_bytes + 1 - text.size()));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) ThrowIo(path, "io.unreadable", fmt::format("cannot read the model file: {}", std::strerror(errno)), "check the file");
    if (n == 0) break;
    text.append(buffer, static_cast<size_t>(n));
  }
  return LoadModelString(text, path, limits);
}

}  // namespace multibond
