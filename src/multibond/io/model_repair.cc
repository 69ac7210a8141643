#include "multibond/io/model_repair.h"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "multibond/compile/compiled_model.h"
#include "multibond/core/structure.h"
#include "multibond/io/model_loader.h"
#include "multibond/version.h"

namespace multibond {

namespace {

constexpr size_t npos = std::string::npos;

struct Edit {
  size_t pos, len;
  std::string text;
};

size_t LineStart(const std::string& s, size_t pos) {
  if (pos == 0) return 0;
  const size_t nl = s.rfind('\n', pos - 1);
  return nl == npos ? 0 : nl + 1;
}

/// The end of the line holding `pos`, before its "\r\n" or "\n".
size_t LineEnd(const std::string& s, size_t pos) {
  size_t e = s.find('\n', pos);
  if (e == npos) e = s.size();
  if (e > pos && s[e - 1] == '\r') --e;
  return e;
}

/// Past the closing quote of the quoted scalar opening at i.
size_t SkipQuoted(const std::string& s, size_t i) {
  const char q = s[i];
  for (size_t k = i + 1; k < s.size(); ++k) {
    if (q == '"' && s[k] == '\\') {
      ++k;
    } else if (s[k] == q) {
      if (q == '\'' && k + 1 < s.size() && s[k + 1] == '\'') {
        ++k;  // '' is a quote inside a single-quoted scalar
        continue;
      }
      return k + 1;
    }
  }
  throw std::runtime_error("unterminated quoted text in the model file");
}

/// Past the bracket that closes the flow collection opening at i (quotes and comments respected).
size_t SkipFlow(const std::string& s, size_t i) {
  int depth = 0;
  for (size_t k = i; k < s.size(); ++k) {
    const char ch = s[k];
    if (ch == '"' || ch == '\'') {
      k = SkipQuoted(s, k) - 1;
    } else if (ch == '#' && (k == 0 || s[k - 1] == ' ' || s[k - 1] == '\t')) {
      k = LineEnd(s, k);
    } else if (ch == '[' || ch == '{') {
      ++depth;
    } else if ((ch == ']' || ch == '}') && --depth == 0) {
      return k + 1;
    }
  }
  throw std::runtime_error("unbalanced brackets in the model file");
}

bool Blank(const std::string& s, size_t from, size_t to) {
  for (size_t k = from; k < to; ++k)
    if (s[k] != ' ' && s[k] != '\t') return false;
  return true;
}

/// Indentation of the line starting at `start`, or -1 for a blank or comment-only line.
int ContentIndent(const std::string& s, size_t start) {
  size_t k = start;
  while (k < s.size() && (s[k] == ' ' || s[k] == '\t')) ++k;
  if (k >= s.size() || s[k] == '\n' || s[k] == '\r' || s[k] == '#') return -1;
  return static_cast<int>(k - start);
}

/// The end of the last line, from the line after `pos` on, that is indented more than `column`
/// (blank and comment lines are skipped, not counted): the end of a block node.
size_t BlockEnd(const std::string& s, size_t pos, int column) {
  size_t end = LineEnd(s, pos);
  for (size_t line = s.find('\n', pos); line != npos && line + 1 < s.size(); line = s.find('\n', line + 1)) {
    const int indent = ContentIndent(s, line + 1);
    if (indent < 0) continue;
    if (indent <= column) break;
    end = LineEnd(s, line + 1);
  }
  return end;
}

/// [start, end) of the node starting at byte `pos`: a scalar, a flow collection, or a block
/// mapping that is an item of a block sequence whose dash is at column `dash`.
std::pair<size_t, size_t> NodeSpan(const std::string& s, const YAML::Node& n, bool flow_context, int dash) {
  const size_t pos = n.Mark().pos;
  const char ch = s[pos];
  if (n.IsMap() && n.Style() == YAML::EmitterStyle::Block) return {pos, BlockEnd(s, pos, dash)};
  if (n.IsSequence() && n.Style() == YAML::EmitterStyle::Block) return {pos, BlockEnd(s, pos, dash)};
  if (ch == '[' || ch == '{') return {pos, SkipFlow(s, pos)};
  if (ch == '"' || ch == '\'') return {pos, SkipQuoted(s, pos)};
  size_t end = pos;
  for (; end < s.size() && s[end] != '\n' && s[end] != '\r'; ++end) {
    if (s[end] == '#' && end > pos && (s[end - 1] == ' ' || s[end - 1] == '\t')) break;
    if (flow_context && (s[end] == ',' || s[end] == ']' || s[end] == '}')) break;
  }
  while (end > pos && (s[end - 1] == ' ' || s[end - 1] == '\t')) --end;
  return {pos, end};
}

std::string Trim(const std::string& x) {
  const size_t a = x.find_first_not_of(" \t"), z = x.find_last_not_of(" \t");
  return a == npos ? std::string() : x.substr(a, z - a + 1);
}

/// The ends of a bond item as the loader reads them ("" if it is not a bond).
std::pair<std::string, std::string> BondEnds(const YAML::Node& b) {
  if (b.IsScalar()) {
    const std::string s = b.Scalar();
    const size_t arrow = s.find("->");
    if (arrow == npos) return {};
    return {Trim(s.substr(0, arrow)), Trim(s.substr(arrow + 2))};
  }
  if (b.IsSequence() && b.size() == 2) return {b[0].Scalar(), b[1].Scalar()};
  if (b.IsMap() && b["from"] && b["to"]) return {b["from"].Scalar(), b["to"].Scalar()};
  return {};
}

/// A bond from -> to in the form of the original item `b` (with its dim, and its name if `named`).
std::string BondText(const YAML::Node& b, const std::string& from, const std::string& to, bool named) {
  if (b.IsScalar()) return fmt::format("{} -> {}", from, to);
  if (b.IsSequence()) return fmt::format("[{}, {}]", from, to);
  std::string s = fmt::format("{{from: {}, to: {}", from, to);
  if (named && b["name"]) s += fmt::format(", name: {}", b["name"].Scalar());
  if (b["dim"]) s += fmt::format(", dim: {}", b["dim"].Scalar());
  return s + "}";
}


/// The new elements of one coupling, as "name: {spec}" entries with a trailing comment each.
std::vector<std::pair<std::string, std::string>> ElementEntries(const SuggestedCoupling& c) {
  const char* effort = c.domain == "rotation"      ? "torque"
                       : c.domain == "translation" ? "force"
                       : c.domain == "electrical"  ? "voltage"
                       : c.domain == "hydraulic"   ? "pressure"
                                                   : "effort";
  return {
      {fmt::format("{}: {{type: \"0\"}}", c.zero), fmt::format("the coupling's {} on both sides", effort)},
      {fmt::format("{}: {{type: \"1\"}}", c.one), fmt::format("deflection rate {}.f - {}.f", c.tail, c.head)},
      {fmt::format("{}: {{type: C, stiffness: {}}}", c.spring, ParamYaml(c.stiffness)), "K = m_eff (2 pi f)^2"},
      {fmt::format("{}: {{type: R, resistance: {}}}", c.damper, ParamYaml(c.damping)), "R = 2 zeta sqrt(K m_eff)"},
  };
}

/// Loads the edited text and checks it as `multibond check` does; returns the number of states.
int CheckRepaired(const std::string& text, const std::string& file) {
  try {
    const LoadedModel lm = LoadModelString(text, file);
    DiagnosticSink sink;
    const BondGraph view = CausalView(lm.graph);  // rigid joints are solved, not derivative causality
    const Structure s = AnalyzeStructure(view, lm.compile.default_domain, sink);
    sink.ThrowIfErrors();
    const CausalAssignment c = AssignCausality(view, s);
    if (c.has_errors()) throw ModelError(c.diagnostics);
    return CompiledModel::Compile(lm.graph, lm.compile)->num_states();
  } catch (const ModelError& e) {
    std::string first;
    for (const auto& d : e.diagnostics())
      if (d.severity == Diagnostic::Severity::kError) {
        first = d.ToString();
        break;
      }
    throw std::runtime_error("the repaired model does not check:\n" + first);
  }
}

}  // namespace

std::string ParamYaml(const Eigen::MatrixXd& m) { return MatrixText(m, true); }

RepairedText RepairModelText(const std::string& text, const std::string& file, const RepairResult& repair,
                             const CouplingTarget& target) {
  if (repair.couplings.empty()) throw std::runtime_error("there is nothing to repair");
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("the model file is not valid YAML: " + e.msg);
  }
  if (root["bodies"])
    throw std::runtime_error("a mechanism file (bodies, joints) is repaired in its own terms: give the connection a "
                             "joint, gear mesh or velocity drive with K and R");
  const YAML::Node bonds = root["bonds"], elements = root["elements"];
  if (!bonds || !bonds.IsSequence() || !elements || !elements.IsMap() || elements.size() == 0)
    throw std::runtime_error("the model file has no top-level 'bonds' list and 'elements' mapping to edit");

  std::vector<Edit> edits;
  // 1. Each replaced bond, found by the position the loader recorded for it.
  const bool flow_bonds = bonds.Style() == YAML::EmitterStyle::Flow;
  for (const SuggestedCoupling& c : repair.couplings) {
    int index = -1;
    for (size_t k = 0; k < bonds.size(); ++k)
      if (bonds[k].Mark().line + 1 == c.where.line && bonds[k].Mark().column + 1 == c.where.column) index = static_cast<int>(k);
    if (index < 0 || c.where.file != file)
      throw std::runtime_error(fmt::format("the bond '{}' is not in the file's top-level 'bonds' list (it comes from a "
                                           "submodel definition or a mechanism section): insert the coupling by hand",
                                           c.bond));
    const YAML::Node item = bonds[index];
    const auto [from, to] = BondEnds(item);
    if (from != c.tail || to != c.head)
      throw std::runtime_error(fmt::format("the bond at {} reads '{} -> {}', expected '{} -> {}'", c.where.ToString(), from, to,
                                           c.tail, c.head));
    const bool storage_is_head = c.head == c.storage;
    const std::string first = BondText(item, c.tail, c.zero, !storage_is_head);
    const std::string second = BondText(item, c.zero, c.head, storage_is_head);
    // The coupling's own bonds: 0 -> 1, and the C and R on the 1-junction.
    const std::vector<std::string> coupling = {BondText(item, c.zero, c.one, false), BondText(item, c.one, c.spring, false),
                                               BondText(item, c.one, c.damper, false)};
    const size_t pos = item.Mark().pos, line = LineStart(text, pos);
    if (flow_bonds) {
      const auto [start, end] = NodeSpan(text, item, true, 0);
      std::string all = first + ", " + second;
      for (const auto& b : coupling) all += ", " + b;
      edits.push_back({start, end - start, all});
      continue;
    }
    // A block list: the item is the first thing on its line after "- ".
    const std::string prefix = text.substr(line, pos - line);
    const size_t dash = prefix.find('-');
    if (dash == npos || !Blank(prefix, 0, dash) || !Blank(prefix, dash + 1, prefix.size()) || dash + 1 == prefix.size())
      throw std::runtime_error(fmt::format("cannot edit the bond at {}: expected it on its own line after '- '", c.where.ToString()));
    const auto [start, end] = NodeSpan(text, item, false, static_cast<int>(dash));
    const std::string indent = prefix.substr(0, dash);
    edits.push_back({line, 0,
                     fmt::format("{}# multibond check --suggest: '{} -> {}' replaced by a compliant coupling ({}, {}, {}, {})\n",
                                 indent, c.tail, c.head, c.zero, c.one, c.spring, c.damper)});
    edits.push_back({start, end - start, first});
    const size_t eol = LineEnd(text, end);
    std::string after = "\n" + prefix + second;
    for (const auto& b : coupling) after += "\n" + prefix + b;
    edits.push_back({eol, 0, after});
  }

  // 2. The new elements, at the end of the top-level 'elements' mapping.
  std::vector<std::string> entries;
  std::vector<std::string> comments;
  for (const SuggestedCoupling& c : repair.couplings)
    for (auto& [entry, comment] : ElementEntries(c)) entries.push_back(entry), comments.push_back(comment);
  if (elements.Style() == YAML::EmitterStyle::Flow) {
    const size_t close = SkipFlow(text, elements.Mark().pos) - 1;
    std::string add;
    for (const auto& e : entries) add += ", " + e;
    edits.push_back({close, 0, add});
  } else {
    size_t last = 0;
    int column = -1;
    for (const auto& kv : elements) {
      last = std::max(last, static_cast<size_t>(kv.first.Mark().pos));
      if (column < 0) column = kv.first.Mark().column;
    }
    const size_t end = BlockEnd(text, last, column);
    const std::string indent(column, ' ');
    size_t width = 0;
    for (const auto& e : entries) width = std::max(width, e.size());
    std::string add;
    for (size_t k = 0; k < entries.size(); ++k) {
      if (k % 4 == 0) {
        const SuggestedCoupling& c = repair.couplings[k / 4];
        const CouplingUnits u = CouplingUnitsOf(c.domain);
        add += fmt::format("\n{}# compliant coupling of I '{}' (multibond check --suggest: f = {:g} Hz, zeta = {:g}, m_eff = {}", indent,
                           c.storage, target.frequency_hz, target.damping_ratio, ParamYaml(c.m_eff));
        add += u.inertia == "-" ? ")" : fmt::format(" {}; K in {}, R in {})", u.inertia, u.stiffness, u.resistance);
      }
      add += fmt::format("\n{}{:<{}}  # {}", indent, entries[k], width, comments[k]);
    }
    edits.push_back({end, 0, add});
  }

  // 3. A note at the top.
  std::string names;
  for (const SuggestedCoupling& c : repair.couplings) names += (names.empty() ? "" : ", ") + fmt::format("'{}'", c.storage);
  edits.push_back({0, 0,
                   fmt::format("# Repaired by 'multibond check --suggest --write' (multibond {}) from {}:\n"
                               "# {} compliant coupling{} (a C and an R on the deflection rate) for {}, tuned to f = {:g} Hz,\n"
                               "# zeta = {:g}. Comments below that describe the rigid model may no longer hold.\n",
                               kVersion, file, repair.couplings.size(), repair.couplings.size() == 1 ? "" : "s", names,
                               target.frequency_hz, target.damping_ratio)});

  // Apply from the end of the text so that earlier positions stay valid; at one position, in the
  // order the edits were made.
  std::stable_sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.pos > b.pos; });
  for (size_t k = 1; k < edits.size(); ++k)
    if (edits[k].pos + edits[k].len > edits[k - 1].pos && edits[k].len > 0)
      throw std::runtime_error("overlapping edits of the model file (two couplings on one bond?)");
  // Line breaks as in the file (the edits are written with "\n").
  if (text.find("\r\n") != npos)
    for (Edit& e : edits)
      for (size_t k = e.text.find('\n'); k != npos; k = e.text.find('\n', k + 2)) e.text.replace(k, 1, "\r\n");
  RepairedText out{text, 0};
  // Insertions at one position: apply the last made first, so that they end up in order.
  for (size_t k = 0; k < edits.size();) {
    size_t e = k;
    while (e < edits.size() && edits[e].pos == edits[k].pos) ++e;
    for (size_t j = e; j-- > k;) out.text.replace(edits[j].pos, edits[j].len, edits[j].text);
    k = e;
  }
  out.states = CheckRepaired(out.text, file);
  return out;
}

}  // namespace multibond
