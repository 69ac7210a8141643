#include "multibond/compile/equations.h"

#include <algorithm>
#include <deque>
#include <functional>
#include <map>
#include <queue>
#include <set>
#include <utility>

#include <fmt/format.h>

#include "multibond/compile/formula_latex.h"

namespace multibond {

namespace {

constexpr long long kBudget = 60;           // leaf symbols per expression before junction variables are named
constexpr long long kSaturate = 1LL << 40;  // leaf and route counts of a DAG can grow exponentially
constexpr int kMaxPaths = 12;               // causal paths printed per equation
constexpr long long kMaxRoutes = 20000;     // routes walked per equation when listing paths

long long SatAdd(long long a, long long b) { return std::min(kSaturate, a + b); }

/// A symbolic expression. Leaves and references carry no sign: signs (and coefficients) live on
/// kLinear nodes, so that sums can be flattened and printed as "a - b" rather than "a + -1*b".
struct Expr {
  enum class Kind { kLeaf, kRef, kLinear, kSum };
  Kind kind = Kind::kLeaf;
  std::string text, latex;     ///< leaf/ref symbol, or the kLinear coefficient ("" = none)
  double sign = 1.0;           ///< kLinear
  std::vector<Expr> children;  ///< kLinear: one; kSum: the terms
};

Expr Signed(double sign, std::string text, std::string latex, Expr child) {
  if (sign > 0 && text.empty()) return child;
  Expr e;
  e.kind = Expr::Kind::kLinear;
  e.sign = sign < 0 ? -1.0 : 1.0;
  e.text = std::move(text);
  e.latex = std::move(latex);
  e.children.push_back(std::move(child));
  return e;
}

/// The signed terms of a sum after distributing signs and dropping bare signs and nested sums.
void Flatten(const Expr& e, double sign, std::vector<std::pair<double, const Expr*>>& out) {
  if (e.kind == Expr::Kind::kSum) {
    for (const Expr& c : e.children) Flatten(c, sign, out);
  } else if (e.kind == Expr::Kind::kLinear && e.text.empty()) {
    Flatten(e.children.front(), sign * e.sign, out);
  } else if (e.kind == Expr::Kind::kLinear) {
    out.emplace_back(sign * e.sign, &e);  // the node's own sign is folded into the term's
  } else {
    out.emplace_back(sign, &e);
  }
}

std::string Render(const Expr& e, bool latex);

std::string RenderTerm(const Expr& e, bool latex) {
  if (e.kind != Expr::Kind::kLinear) return latex ? e.latex : e.text;
  // A coefficient times a factor; the factor is parenthesised unless it is a single positive term.
  std::vector<std::pair<double, const Expr*>> inner;
  Flatten(e.children.front(), 1.0, inner);
  std::string factor;
  if (inner.size() == 1 && inner.front().first > 0) {
    factor = RenderTerm(*inner.front().second, latex);
  } else {
    factor = Render(e.children.front(), latex);
    factor = latex ? "\\left(" + factor + "\\right)" : "(" + factor + ")";
  }
  return latex ? e.latex + " \\, " + factor : e.text + " * " + factor;
}

std::string Render(const Expr& e, bool latex) {
  std::vector<std::pair<double, const Expr*>> terms;
  Flatten(e, 1.0, terms);
  if (terms.empty()) return "0";
  std::string out;
  for (const auto& [sign, term] : terms) {
    if (out.empty()) out = sign < 0 ? "-" : "";
    else out += sign < 0 ? " - " : " + ";
    out += RenderTerm(*term, latex);
  }
  return out;
}

/// Text usable inside \mathrm{}: LaTeX specials escaped.
std::string LatexEscape(const std::string& s) {
  std::string out;
  for (size_t k = 0; k < s.size(); ++k) {
    const char ch = s[k];
    if (ch == '-' && k + 1 < s.size() && s[k + 1] == '>') {  // default bond names "a->b"
      out += "{\\to}";
      ++k;
      continue;
    }
    switch (ch) {
      case '_': out += "\\_"; break;
      case '{': out += "\\{"; break;
      case '}': out += "\\}"; break;
      case '#': out += "\\#"; break;
      case '$': out += "\\$"; break;
      case '%': out += "\\%"; break;
      case '&': out += "\\&"; break;
      case '^': out += "\\hat{}"; break;
      case '~': out += "\\sim{}"; break;
      case '\\': out += "\\backslash{}"; break;
      case ' ': out += "\\ "; break;
      case '\n': out += "\\ "; break;
      default: out += ch;
    }
  }
  return out;
}

std::string Rm(const std::string& s) { return "\\mathrm{" + LatexEscape(s) + "}"; }

/// "sym_{\mathrm{name}}".
std::string Sub(const std::string& sym, const std::string& name) { return sym + "_{" + Rm(name) + "}"; }

/// A comment line must stay one line.
std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  return s;
}

class EquationWriter {
 public:
  EquationWriter(const CompiledModel& m, EquationFormat f)
      : m_(m), g_(m.graph()), latex_(f == EquationFormat::kLatex) {
    const int nc = m_.num_slot_classes();
    full_.assign(nc, -1);
    routes_.assign(nc, -1);
    class_bonds_.resize(nc);
    for (int b = 0; b < g_.num_bonds(); ++b) {
      class_bonds_[m_.slot_class_of_effort(b)].push_back(b);
      class_bonds_[m_.slot_class_of_flow(b)].push_back(b);
    }
    is_effort_.assign(nc, false);
    for (int b = 0; b < g_.num_bonds(); ++b) is_effort_[m_.slot_class_of_effort(b)] = true;
    torn_.assign(nc, false);
    for (const auto& loop : m_.algebraic_loops()) torn_[loop.slot_class] = true;
    RankClasses();
  }

  std::string Run() {
    std::string out;
    const std::string title = fmt::format("State equations of model '{}'", g_.name());
    out += latex_ ? "% " + OneLine(title) + " (rows for an align* environment)\n" : title + "\n";
    std::vector<std::string> energy;
    int count = 0;
    for (const StateBlock& blk : m_.state_blocks()) {
      if (blk.kind == StateBlock::Kind::kWork || blk.kind == StateBlock::Kind::kDissipation) {
        energy.push_back(m_.state_names()[blk.offset]);
        continue;
      }
      WriteEquation(blk);
      ++count;
    }
    if (count == 0) rows_.push_back({latex_ ? "" : "(no state equations: the model has no storage elements or auxiliary states)", {}});
    for (size_t r = 0; r < rows_.size(); ++r) {
      if (!latex_) out += "\n";
      if (!rows_[r].line.empty()) {
        out += rows_[r].line;
        // align* rows are separated, not terminated, by \\ (a trailing one adds an empty row).
        if (latex_ && r + 1 < rows_.size()) out += " \\\\";
        out += "\n";
      }
      for (const std::string& c : rows_[r].notes) out += c + "\n";
    }
    // Signals (and the parts of signal states): formulas of named variables, one line each.
    std::string signals;
    for (int c = 0; c < m_.num_slot_classes(); ++c)
      if (Def(c).kind == Definition::Kind::kFormula && Def(c).element < 0)
        signals += latex_ ? fmt::format("% signal: {} = {}\n", OneLine(m_.slot_class_name(c)), OneLine(Def(c).formula))
                          : fmt::format("  {} = {}\n", m_.slot_class_name(c), Def(c).formula);
    if (!signals.empty()) out += latex_ ? signals : "\nsignals:\n" + signals;
    for (const auto& loop : m_.algebraic_loops()) {
      const std::string text = LoopEquation(loop);
      out += latex_ ? "% " + OneLine(text) + "\n" : "\n" + text + "\n";
    }
    if (m_.has_constraints()) {
      std::string names;
      for (const std::string& n : m_.constraint_names()) names += (names.empty() ? "" : ", ") + n;
      const std::string line = fmt::format(
          "ideal constraints: the efforts lambda[...] ({} multipliers: {}) are solved at every evaluation so that each "
          "constraint's flows keep their prescribed values exactly (docs/design.md, \"Ideal constraints\")",
          m_.num_multipliers(), names);
      out += latex_ ? "% " + OneLine(line) + "\n" : "\n" + line + "\n";
    }
    if (!energy.empty()) {
      std::string names;
      for (const std::string& n : energy) names += (names.empty() ? "" : ", ") + n;
      const std::string line = fmt::format(
          "energy account: the work of each source and the energy dissipated in each resistor are integrated as "
          "extra states ({}); they do not feed back into the equations above",
          names);
      out += latex_ ? "% " + OneLine(line) + "\n" : "\n" + line + "\n";
      // And the work of each modulated storage element's modulation, the integral of its power
      // (compile/modulated_storage.cc).
      for (const StateBlock& blk : m_.state_blocks())
        if (blk.kind == StateBlock::Kind::kWork && blk.rate_class >= 0) {
          const std::string rate = fmt::format("d({})/dt = {}", m_.state_names()[blk.offset], Def(blk.rate_class).formula);
          out += latex_ ? "% " + OneLine(rate) + "\n" : "  " + rate + "\n";
        }
    }
    return out;
  }

 private:
  struct Row {
    std::string line;
    std::vector<std::string> notes;  ///< lines printed under it (where-block in text, paths)
  };

  const Definition& Def(int c) const { return m_.definition(c); }

  /// Sources, inertia flows, compliance efforts, and the variables algebraic loops are torn at
  /// (named unknowns, defined in a line of their own).
  bool IsLeaf(int c) const {
    if (torn_[c]) return true;
    const Definition::Kind k = Def(c).kind;
    return k == Definition::Kind::kSource || k == Definition::Kind::kMomentumFlow ||
           k == Definition::Kind::kStiffnessEffort || k == Definition::Kind::kFormula;
  }

  /// Slot classes in evaluation order (inputs before outputs), ties broken by index.
  void RankClasses() {
    const int nc = m_.num_slot_classes();
    std::vector<int> indegree(nc, 0);
    std::vector<std::vector<int>> users(nc);
    for (int c = 0; c < nc; ++c)
      if (!IsLeaf(c))
        for (const Definition::Term& t : Def(c).terms) {
          users[t.slot_class].push_back(c);
          ++indegree[c];
        }
    std::priority_queue<int, std::vector<int>, std::greater<int>> ready;
    for (int c = 0; c < nc; ++c)
      if (indegree[c] == 0) ready.push(c);
    rank_.assign(nc, nc);  // a class on a cycle (impossible after Compile) sorts last
    int next = 0;
    while (!ready.empty()) {
      const int c = ready.top();
      ready.pop();
      rank_[c] = next++;
      for (int u : users[c])
        if (--indegree[u] == 0) ready.push(u);
    }
  }

  /// Leaf symbols of the fully inlined definition of c.
  long long Full(int c) {
    if (full_[c] >= 0) return full_[c];
    long long n = 1;
    if (!IsLeaf(c)) {
      n = 0;
      full_[c] = kSaturate;  // guards against a cycle
      for (const Definition::Term& t : Def(c).terms) n = SatAdd(n, Full(t.slot_class));
    }
    return full_[c] = n;
  }

  /// Number of leaf-to-c routes through the definitions.
  long long Routes(int c) {
    if (routes_[c] >= 0) return routes_[c];
    long long n = 1;
    if (!IsLeaf(c)) {
      n = 0;
      routes_[c] = kSaturate;
      for (const Definition::Term& t : Def(c).terms) n = SatAdd(n, Routes(t.slot_class));
    }
    return routes_[c] = n;
  }

  const std::string& Name(int element) const { return g_.element(element).name; }

  Expr MakeLeaf(std::string text, std::string latex) const {
    Expr e;
    e.kind = Expr::Kind::kLeaf;
    e.text = std::move(text);
    e.latex = std::move(latex);
    return e;
  }

  /// The state's name as in the results ("B.h" for a body's inertia with state_name "B.h").
  std::string StateOf(const Element& el) const {
    if (!el.state_name.empty()) return el.state_name;
    return el.name + (el.kind == ElementKind::kI ? ".p" : ".q");
  }

  Expr Leaf(int c) const {
    if (torn_[c]) return Ref(c);
    const Definition& d = Def(c);
    // A formula (signals have no element), shown as written in named variables.
    if (d.kind == Definition::Kind::kFormula) {
      // In brackets when it starts with a sign, which the sum it stands in may double ("- -a").
      const std::string f = !d.formula.empty() && (d.formula[0] == '-' || d.formula[0] == '+') ? "(" + d.formula + ")" : d.formula;
      const std::optional<std::string> math = FormulaLatex(f);
      return MakeLeaf(f, math ? "\\left(" + *math + "\\right)" : "\\mathtt{" + LatexEscape(f) + "}");
    }
    const Element& el = g_.element(d.element);
    const std::string& n = el.name;
    const std::string state = StateOf(el);
    switch (d.kind) {
      case Definition::Kind::kSource:
        if (el.constraint) {
          // An ideal constraint's effort: the multiplier (both sides of a cut share it).
          std::string group = n;
          if (group.size() > 5 && group.compare(group.size() - 5, 5, ".rest") == 0) group.resize(group.size() - 5);
          return MakeLeaf("lambda[" + group + "]", "\\lambda_{" + Rm(group) + "}");
        }
        {
          // A constant source is a constant in the mathematics (the text keeps its "(t)").
          bool constant = !el.source.components.empty();
          for (const TimeFunction& f : el.source.components) constant = constant && f.is_constant();
          for (const Formula& f : el.value) constant = constant && !f.given();
          return MakeLeaf(n + "(t)", Rm(n) + (constant ? "" : "(t)"));
        }
      case Definition::Kind::kMomentumFlow:
        if (!el.rotation.empty()) {
          // f = R Ib^-1 R^T h: the body-frame inertia turned into the inertial frame.
          const std::string& r = el.rotation;
          return MakeLeaf(fmt::format("{0} inv({1}.Ib) {0}^T {2}", r, n, state),
                          fmt::format("{0} \\, \\left(I^{{b}}_{{{1}}}\\right)^{{-1}} \\, {0}^{{\\top}} \\, {2}", Rm(r),
                                      Rm(n), Sub("p", n)));
        }
        if (el.param.is_scalar)
          return MakeLeaf(state + "/" + n + ".I", Sub("I", n) + "^{-1} \\, " + Sub("p", n));
        return MakeLeaf("inv(" + n + ".I) " + state, Sub("I", n) + "^{-1} \\, " + Sub("p", n));
      case Definition::Kind::kStiffnessEffort: {
        // sigma e = K q: the effort is -K q when the bond points out of the C.
        const double sigma = g_.PowerSign(el.bonds.front(), d.element);
        return Signed(sigma, "", "", MakeLeaf(n + ".K " + state, Sub("K", n) + " \\, " + Sub("q", n)));
      }
      default:
        break;
    }
    MB_ASSERT(false, "Leaf called on a computed slot class");
    return {};
  }

  /// A junction variable referred to by name ("j1.f" -> f_{j1}, "gear.e2" -> e_{gear,2}).
  Expr Ref(int c) const {
    const std::string& name = m_.slot_class_name(c);
    std::string latex = Rm(name);
    const auto dot = name.rfind('.');
    if (dot != std::string::npos && dot > 0) {
      const std::string base = name.substr(0, dot), var = name.substr(dot + 1);
      if (var == "e" || var == "f") latex = Sub(var, base);
      if (var == "e1" || var == "e2" || var == "f1" || var == "f2")
        latex = var.substr(0, 1) + "_{" + Rm(base) + "," + var.substr(1) + "}";
    }
    Expr e = MakeLeaf(name, std::move(latex));
    e.kind = Expr::Kind::kRef;
    return e;
  }

  /// Wraps `child` in the coefficient and sign of a kLinear definition's term.
  Expr Apply(const Definition& d, const Definition::Term& t, Expr child) const {
    const Element& el = g_.element(d.element);
    double sign = t.sign;
    // An R's coefficient symbol stands for its (non-negative) resistance; the orientation sign
    // sigma (e = sigma R f) is folded into the matrix the plan multiplies by, not into the term's
    // sign, so it is recovered from the graph here.
    if (el.kind == ElementKind::kR) sign = g_.PowerSign(el.bonds.front(), d.element);
    if (t.coef.empty()) return Signed(sign, "", "", std::move(child));
    auto [text, latex] = Coefficient(el, t.coef);
    return Signed(sign, text, latex, std::move(child));
  }

  /// Text and LaTeX of a coefficient symbol "name.sym", "name.sym^T|^-1|^-T" or "1/name.sym".
  std::pair<std::string, std::string> Coefficient(const Element& el, const std::string& coef) const {
    std::string rest = coef;
    const bool reciprocal = rest.rfind("1/", 0) == 0;
    if (reciprocal) rest = rest.substr(2);
    const std::string prefix = el.name + ".";
    if (rest.rfind(prefix, 0) != 0) return {coef, Rm(coef)};
    std::string sym = rest.substr(prefix.size()), suffix;
    if (const auto caret = sym.find('^'); caret != std::string::npos) {
      suffix = sym.substr(caret);
      sym = sym.substr(0, caret);
    }
    // A scalar ratio is its own transpose.
    const bool scalar = (el.kind == ElementKind::kTF || el.kind == ElementKind::kGY) && el.param.is_scalar;
    if (scalar && suffix == "^T") suffix.clear();
    if (scalar && suffix == "^-T") suffix = "^-1";
    std::string text = (reciprocal ? "1/" : "") + prefix + sym + suffix;
    std::string latex = Sub(LatexEscape(sym), el.name);
    if (suffix == "^T") latex += "^{\\top}";
    else if (suffix == "^-1" || reciprocal) latex += "^{-1}";
    else if (suffix == "^-T") latex += "^{-\\top}";
    else if (!suffix.empty()) latex += "^{" + LatexEscape(suffix.substr(1)) + "}";
    return {text, latex};
  }

  Expr Inline(int c) { return IsLeaf(c) ? Leaf(c) : Body(c); }

  /// The definition of a computed class with its inputs inlined.
  Expr Body(int c) {
    const Definition& d = Def(c);
    if (d.kind == Definition::Kind::kLinear) return Apply(d, d.terms.front(), Inline(d.terms.front().slot_class));
    Expr sum;
    sum.kind = Expr::Kind::kSum;
    for (const Definition::Term& t : d.terms) sum.children.push_back(Signed(t.sign, "", "", Inline(t.slot_class)));
    return sum;
  }

  /// The expression of slot class c with at most about `budget` leaf symbols: what does not fit is
  /// cut at junction variables (sums), which are added to `refs`. The root is always expanded.
  Expr Build(int c, long long budget, bool root, long long* used, std::set<int>* refs) {
    if (Full(c) <= budget) {
      *used = std::max(1LL, Full(c));
      return Inline(c);
    }
    const Definition& d = Def(c);
    if (d.kind == Definition::Kind::kLinear)  // a coefficient costs no symbol: look through it
      return Apply(d, d.terms.front(), Build(d.terms.front().slot_class, budget, root, used, refs));
    const long long n = static_cast<long long>(d.terms.size());
    if (!root && budget < n) {
      refs->insert(c);
      *used = 1;
      return Ref(c);
    }
    // Every term gets one symbol; the rest goes to the terms that fit whole, in order, then to the
    // others, which are expanded as far as it goes.
    long long spare = std::max(0LL, budget - n);
    std::vector<bool> whole(d.terms.size(), false);
    for (size_t k = 0; k < d.terms.size(); ++k) {
      const long long cost = std::max(1LL, Full(d.terms[k].slot_class)) - 1;
      if (cost <= spare) {
        whole[k] = true;
        spare -= cost;
      }
    }
    Expr sum;
    sum.kind = Expr::Kind::kSum;
    *used = 0;
    for (size_t k = 0; k < d.terms.size(); ++k) {
      const Definition::Term& t = d.terms[k];
      long long u = 0;
      Expr child = whole[k] ? Inline(t.slot_class) : Build(t.slot_class, 1 + spare, false, &u, refs);
      if (whole[k]) {
        u = std::max(1LL, Full(t.slot_class));
      } else {
        spare = std::max(0LL, spare - (u - 1));
      }
      *used += u;
      sum.children.push_back(Signed(t.sign, "", "", std::move(child)));
    }
    return sum;
  }

  // --- causal paths ---

  /// The junctions that share slot class c between the element that defines it and `consumer`,
  /// ordered from the definer to the consumer (e.g. mass's flow reaching spring through 1 'j').
  const std::vector<int>& JunctionsBetween(int c, int consumer) {
    const auto key = std::make_pair(c, consumer);
    if (auto it = junctions_.find(key); it != junctions_.end()) return it->second;
    std::vector<int>& out = junctions_[key];
    const int definer = Def(c).element;
    const ElementKind sharing = is_effort_[c] ? ElementKind::kZero : ElementKind::kOne;
    auto touches = [&](int b, int e) { return g_.bond(b).from == e || g_.bond(b).to == e; };
    std::map<int, std::pair<int, int>> parent;  // bond -> (previous bond, junction crossed)
    std::deque<int> queue;
    for (int b : class_bonds_[c])
      if (touches(b, consumer)) {
        if (touches(b, definer)) return out;
        parent[b] = {-1, -1};
        queue.push_back(b);
      }
    while (!queue.empty()) {
      const int b = queue.front();
      queue.pop_front();
      for (int j : {g_.bond(b).from, g_.bond(b).to}) {
        if (j == consumer || j == definer || g_.element(j).kind != sharing) continue;
        for (int b2 : g_.element(j).bonds) {
          if (parent.count(b2)) continue;
          parent[b2] = {b, j};
          if (touches(b2, definer)) {
            for (int x = b2; parent[x].first >= 0 || parent[x].second >= 0; x = parent[x].first)
              out.push_back(parent[x].second);
            return out;
          }
          queue.push_back(b2);
        }
      }
    }
    return out;
  }

  struct PathWalk {
    std::vector<int> stack;  ///< from the state's element down to the current definer
    std::vector<std::vector<int>> paths;
    std::set<std::vector<int>> seen;
    long long routes = 0;
  };

  void Walk(int c, int consumer, PathWalk& w) {
    if (w.routes >= kMaxRoutes) return;
    const Definition& d = Def(c);
    const size_t mark = w.stack.size();
    const std::vector<int> chain = JunctionsBetween(c, consumer);
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) w.stack.push_back(*it);
    w.stack.push_back(d.element);
    if (IsLeaf(c)) {
      ++w.routes;
      std::vector<int> path;
      for (auto it = w.stack.rbegin(); it != w.stack.rend(); ++it)
        if (path.empty() || path.back() != *it) path.push_back(*it);
      if (w.seen.insert(path).second) w.paths.push_back(std::move(path));
    } else {
      for (const Definition::Term& t : d.terms) Walk(t.slot_class, d.element, w);
    }
    w.stack.resize(mark);
  }

  std::vector<std::string> PathLines(int c, int consumer) {
    PathWalk w;
    w.stack.push_back(consumer);
    Walk(c, consumer, w);
    const long long total = w.routes >= kMaxRoutes ? std::max<long long>(Routes(c), w.paths.size())
                                                   : static_cast<long long>(w.paths.size());
    std::vector<std::string> lines;
    const std::string prefix = latex_ ? "% path: " : "  path: ";
    for (size_t k = 0; k < w.paths.size() && k < static_cast<size_t>(kMaxPaths); ++k)
      if (const std::string path = FormatPath(g_, w.paths[k]); !path.empty())  // signals have no elements
        lines.push_back(prefix + OneLine(path));
    if (total > kMaxPaths)
      lines.push_back(fmt::format("{}... and {}{} more", prefix, total - kMaxPaths, total >= kSaturate ? "+" : ""));
    return lines;
  }

  // --- equations ---

  /// The junction variables an expression was cut at, each expanded the same way (which may name
  /// further ones), in evaluation order.
  std::vector<std::pair<int, Expr>> Intermediates(std::set<int>& refs) {
    std::map<int, Expr> where;
    while (true) {
      int next = -1;
      for (int r : refs)
        if (!where.count(r)) {
          next = r;
          break;
        }
      if (next < 0) break;
      long long u = 0;
      where.emplace(next, Build(next, kBudget, true, &u, &refs));
    }
    std::vector<std::pair<int, Expr>> out(where.begin(), where.end());
    std::sort(out.begin(), out.end(), [&](const auto& a, const auto& b) {
      return std::make_pair(rank_[a.first], a.first) < std::make_pair(rank_[b.first], b.first);
    });
    return out;
  }

  /// An algebraic loop's own equation: the torn variable's definition (its terms built within the
  /// budget, as the state equations are), then the variables it was cut at.
  std::string LoopEquation(const CompiledModel::AlgebraicLoop& loop) {
    const Definition& d = Def(loop.slot_class);
    std::set<int> refs;
    long long used = 0;
    Expr body;
    if (d.kind == Definition::Kind::kFormula || d.terms.empty()) {
      // A nonlinear loop torn at a formula's output (a law, a signal): the formula as written.
      const std::optional<std::string> math = FormulaLatex(d.formula);
      body = MakeLeaf(d.formula, math ? *math : "\\mathtt{" + LatexEscape(d.formula) + "}");
    } else if (d.kind == Definition::Kind::kLinear) {
      body = Apply(d, d.terms.front(), Build(d.terms.front().slot_class, kBudget, true, &used, &refs));
    } else {
      body.kind = Expr::Kind::kSum;
      const long long share = std::max<long long>(1, kBudget / static_cast<long long>(d.terms.size()));
      for (const Definition::Term& t : d.terms)
        body.children.push_back(Signed(t.sign, "", "", Build(t.slot_class, share, false, &used, &refs)));
    }
    std::string text = fmt::format(
        "algebraic loop {}: {} = {}, solved for {} {} at every evaluation (docs/design.md, "
        "\"Algebraic loops\")",
        loop.path, loop.torn, Render(body, false), loop.torn, m_.has_nonlinear_loops() ? "by Newton's method" : "as a linear system");
    for (const auto& [c, e] : Intermediates(refs)) text += fmt::format("\n    where {} = {}", Ref(c).text, Render(e, false));
    return text;
  }

  void WriteEquation(const StateBlock& blk) {
    int cls = -1, consumer = -1;
    double sign = 1.0;
    std::string lhs_text, lhs_latex;
    const bool orientation = blk.kind == StateBlock::Kind::kOrientation;
    std::string state;
    if (blk.kind == StateBlock::Kind::kMomentum || blk.kind == StateBlock::Kind::kDisplacement) {
      const bool momentum = blk.kind == StateBlock::Kind::kMomentum;
      consumer = blk.owner;
      cls = m_.derivative_source(blk);
      sign = m_.derivative_sign(blk);
      state = StateOf(g_.element(blk.owner));
      lhs_latex = "\\dot{" + std::string(momentum ? "p" : "q") + "}_{" + Rm(Name(blk.owner)) + "}";
    } else if (blk.rate_class >= 0) {
      // A signal state (a rate's integral, a lag, a PID's parts): the derivative is a formula's slot.
      cls = blk.rate_class;
      state = m_.state_names()[blk.offset];
      lhs_latex = "\\frac{d}{dt}" + Rm(state);
    } else {
      // Auxiliary states integrate the flow of `of` (owner is an aux index, not an element).
      const AuxState& aux = g_.aux_states().at(blk.owner);
      consumer = g_.Find(aux.of);
      MB_ASSERT(consumer >= 0, "auxiliary state of an unknown element");
      cls = m_.slot_class_of_flow(g_.element(consumer).bonds.front());
      state = aux.name;
      lhs_latex = "\\frac{d}{dt}" + Rm(aux.name);
    }
    lhs_text = "d(" + state + ")/dt";

    std::set<int> refs;
    long long used = 0;
    const Expr rhs = Signed(sign, "", "", Build(cls, kBudget, true, &used, &refs));
    Row row;
    if (orientation) {
      row.line = latex_ ? fmt::format("{} &= [\\omega \\times] \\, {}, \\quad \\omega = {}", lhs_latex, Rm(state),
                                      Render(rhs, true))
                        : fmt::format("{} = [w x] {},  w = {}", lhs_text, state, Render(rhs, false));
    } else {
      row.line = latex_ ? lhs_latex + " &= " + Render(rhs, true) : lhs_text + " = " + Render(rhs, false);
    }

    const std::vector<std::pair<int, Expr>> where = Intermediates(refs);
    std::vector<Row> where_rows;
    if (!where.empty() && !latex_) row.notes.push_back("  where:");
    for (size_t k = 0; k < where.size(); ++k) {
      const Expr ref = Ref(where[k].first);
      if (latex_) {
        where_rows.push_back({fmt::format("{}{} &= {}", k == 0 ? "\\text{where } " : "\\qquad ", ref.latex,
                                          Render(where[k].second, true)),
                              {}});
      } else {
        row.notes.push_back(fmt::format("    {} = {}", ref.text, Render(where[k].second, false)));
      }
    }
    std::vector<std::string> paths = PathLines(cls, consumer);
    if (latex_ && !where_rows.empty()) {
      // In LaTeX the paths follow the last row of the block.
      rows_.push_back(std::move(row));
      for (Row& r : where_rows) rows_.push_back(std::move(r));
      rows_.back().notes = std::move(paths);
    } else {
      row.notes.insert(row.notes.end(), paths.begin(), paths.end());
      rows_.push_back(std::move(row));
    }
  }

  const CompiledModel& m_;
  const BondGraph& g_;
  const bool latex_;
  std::vector<long long> full_, routes_;
  std::vector<int> rank_;
  std::vector<bool> is_effort_;
  std::vector<bool> torn_;  ///< per slot class: an algebraic loop's unknown
  std::vector<std::vector<int>> class_bonds_;
  std::map<std::pair<int, int>, std::vector<int>> junctions_;
  std::vector<Row> rows_;
};

}  // namespace

std::string FormatEquations(const CompiledModel& model, EquationFormat format) {
  return EquationWriter(model, format).Run();
}

}  // namespace multibond
