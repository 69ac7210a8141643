#include "multibond/io/dot_writer.h"

#include "multibond/core/process.h"
#include "multibond/io/safe_text.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>


namespace multibond {

namespace {

/// Every name and text from the graph goes into the DOT file through these (safe_text.h): a name
/// cannot end its string, add attributes or break the file.
std::string Quote(const std::string& s) { return DotString(s); }
std::string HtmlEscape(const std::string& s) { return DotHtmlText(s); }

/// A DOT identifier: bare when it can be, quoted otherwise.
std::string Id(const std::string& s) {
  const bool bare = !s.empty() && !std::isdigit(static_cast<unsigned char>(s.front())) &&
                    std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
  return bare ? s : Quote(s);
}

std::string NodeId(int element) { return fmt::format("e{}", element); }

/// Dotted prefixes of a name, outermost first: "A.B.c" -> {"A", "A.B"}.
std::vector<std::string> Prefixes(const std::string& name) {
  std::vector<std::string> out;
  for (size_t k = 1; k + 1 < name.size(); ++k)
    if (name[k] == '.') out.push_back(name.substr(0, k));
  return out;
}

class DotWriter {
 public:
  DotWriter(const BondGraph& g, const Structure* s, const CausalAssignment* c, const DotOptions& o)
      : g_(g), s_(s), c_(c), o_(o) {}

  std::string Run() {
    MarkDerivative();
    AssignClusters();
    out_ << "digraph " << Quote(g_.name()) << " {\n";
    out_ << "  graph [rankdir=LR, fontname=\"Helvetica\", label=" << Quote(g_.name())
         << ", labelloc=t, nodesep=0.35, ranksep=0.6];\n";
    out_ << "  node [shape=plaintext, fontname=\"Helvetica\", fontsize=12, margin=0.05, width=0, height=0];\n";
    out_ << "  edge [fontname=\"Helvetica\", fontsize=9, arrowsize=0.8];\n";
    EmitContainer("", 1);
    for (int b = 0; b < g_.num_bonds(); ++b) EmitBond(b);
    out_ << "}\n";
    return out_.str();
  }

 private:
  void MarkDerivative() {
    derivative_.assign(g_.num_elements(), "");
    if (!c_) return;
    for (int e : c_->derivative) {
      if (e < 0 || e >= g_.num_elements()) continue;
      std::string why = "derivative causality";
      // The causality analysis explains each one; show its message.
      for (const Diagnostic& d : c_->diagnostics)
        if (d.element == g_.element(e).name && d.message.find("derivative causality") != std::string::npos) {
          why = d.message;
          for (const std::string& line : d.details) why += "\n" + line;
          if (!d.hint.empty()) why += "\nhint: " + d.hint;
          break;
        }
      derivative_[e] = why;
    }
  }

  /// Each element goes to the deepest prefix shared by at least two elements.
  void AssignClusters() {
    cluster_of_.assign(g_.num_elements(), "");
    if (!o_.group_by_prefix) return;
    std::map<std::string, int> count;
    for (const Element& e : g_.elements())
      for (const std::string& p : Prefixes(e.name)) ++count[p];
    auto deepest = [&](const std::vector<std::string>& prefixes) {
      std::string best;
      for (const std::string& p : prefixes)
        if (count[p] >= 2) best = p;
      return best;
    };
    for (int i = 0; i < g_.num_elements(); ++i) {
      const std::string cl = deepest(Prefixes(g_.element(i).name));
      cluster_of_[i] = cl;
      // Register the cluster chain: each cluster's parent is its deepest shared proper prefix.
      for (std::string p = cl; !p.empty() && !parent_.count(p);) {
        std::vector<std::string> up = Prefixes(p + ".x");
        up.pop_back();  // p itself
        const std::string parent = deepest(up);
        parent_[p] = parent;
        p = parent;
      }
    }
    // Nesting asked for by the caller, between clusters that exist, without cycles.
    for (const auto& [inner, outer] : o_.nest) {
      if (inner == outer || !parent_.count(inner) || !parent_.count(outer)) continue;
      bool cycle = false;
      for (std::string p = outer; !p.empty(); p = parent_[p])
        if (p == inner) cycle = true;
      if (!cycle) parent_[inner] = outer;
    }
  }

  /// The nodes and sub-clusters directly in `cluster` ("" = the graph), in element order.
  void EmitContainer(const std::string& cluster, int depth) {
    const std::string indent(2 * depth, ' ');
    std::vector<std::string> emitted;
    for (int i = 0; i < g_.num_elements(); ++i) {
      // The child of `cluster` on the way to element i's cluster, if any.
      std::string child;
      for (std::string p = cluster_of_[i]; !p.empty(); p = parent_[p])
        if (parent_[p] == cluster) {
          child = p;
          break;
        }
      if (child.empty()) {
        if (cluster_of_[i] == cluster) EmitNode(i, indent);
        continue;
      }
      if (std::find(emitted.begin(), emitted.end(), child) != emitted.end()) continue;
      emitted.push_back(child);
      out_ << indent << "subgraph " << Id("cluster_" + child) << " {\n";
      out_ << indent << "  label=" << Quote(child) << "; style=\"rounded,dashed\"; color=gray50; fontcolor=gray30;\n";
      EmitContainer(child, depth + 1);
      out_ << indent << "}\n";
    }
  }

  void EmitNode(int i, const std::string& indent) {
    const Element& e = g_.element(i);
    std::string attrs;
    if (IsJunction(e.kind)) {
      // The junction symbol, with its name in small type underneath.
      attrs = fmt::format("label=<{}<BR/><FONT POINT-SIZE=\"8\">{}</FONT>>", KindName(e.kind), HtmlEscape(e.name));
    } else {
      attrs = "label=" + Quote(fmt::format("{}: {}", KindName(e.kind), e.name));
    }
    if (!derivative_[i].empty()) {
      attrs += ", fontcolor=red, color=red, tooltip=" + Quote(derivative_[i]);
    } else {
      attrs += ", tooltip=" + Quote(Describe(g_, i));
    }
    out_ << indent << NodeId(i) << " [" << attrs << "];\n";
  }

  void EmitBond(int b) {
    const Bond& bond = g_.bond(b);
    if (bond.from < 0 || bond.to < 0) return;
    const std::string& from = g_.element(bond.from).name;
    const std::string& to = g_.element(bond.to).name;
    std::vector<std::string> label;
    // Default names ("a->b") say nothing the drawing does not.
    if (o_.bond_names && !bond.name.empty() && bond.name != from + "->" + to) label.push_back(bond.name);
    int dim = 0;
    if (s_ && b < static_cast<int>(s_->bond_dim.size())) dim = s_->bond_dim[b];
    if (dim > 1) label.push_back(std::to_string(dim));
    std::string label_text;
    for (const std::string& l : label) label_text += (label_text.empty() ? "" : "\n") + l;

    std::string tooltip = fmt::format("bond '{}'", bond.name);
    if (dim > 0) tooltip += fmt::format(", dimension {}", dim);
    std::string attrs;
    const bool known = c_ && b < static_cast<int>(c_->stroke_at_head.size()) &&
                       (b >= static_cast<int>(c_->reason.size()) ||
                        c_->reason[b].why != CausalAssignment::Why::kUnset);
    if (known && c_->stroke_at_head[b]) {
      attrs = "arrowhead=teelvee";
      tooltip += fmt::format("; effort from '{}' to '{}'", from, to);
    } else if (known) {
      attrs = "dir=both, arrowhead=lvee, arrowtail=tee";
      tooltip += fmt::format("; effort from '{}' to '{}'", to, from);
    } else {
      attrs = "arrowhead=lvee";
    }
    if (!label_text.empty()) attrs += ", label=" + Quote(label_text);
    attrs += ", tooltip=" + Quote(tooltip);
    out_ << "  " << NodeId(bond.from) << " -> " << NodeId(bond.to) << " [" << attrs << "];\n";
  }

  const BondGraph& g_;
  const Structure* s_;
  const CausalAssignment* c_;
  const DotOptions& o_;
  std::ostringstream out_;
  std::vector<std::string> derivative_;  ///< per element: why it is in derivative causality ("" = not)
  std::vector<std::string> cluster_of_;
  std::map<std::string, std::string> parent_;  ///< cluster -> enclosing cluster ("" = the graph)
};

/// A path that `dot` cannot mistake for an option.
std::string SafeArg(const std::string& path) { return !path.empty() && path.front() == '-' ? "./" + path : path; }

}  // namespace

std::string MakeDot(const BondGraph& g, const Structure* structure, const CausalAssignment* causality,
                    const DotOptions& options) {
  return DotWriter(g, structure, causality, options).Run();
}

bool RenderWithGraphviz(const std::string& dot_path, const std::vector<GraphvizOutput>& outputs, std::string* error) {
  auto fail = [&](std::string message) {
    if (error) *error = std::move(message);
    return false;
  };
  if (outputs.empty()) return fail("no Graphviz output asked for");
  std::vector<std::string> argv = {"dot"};
  std::string formats;
  for (const GraphvizOutput& o : outputs) {
    const bool format_ok = !o.format.empty() && std::all_of(o.format.begin(), o.format.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == ':' || c == '_';
    });
    if (!format_ok) return fail(fmt::format("invalid Graphviz output format '{}' (expected e.g. svg or png)", o.format));
    argv.insert(argv.end(), {"-T" + o.format, "-o", SafeArg(o.path)});
    formats += (formats.empty() ? "-T" : " -T") + o.format;
  }
  argv.push_back(SafeArg(dot_path));

  // dot's messages go to a temporary file of our own (a unique name, created by mkstemp: not a
  // link someone planted), quoted on failure.
  std::string log = (std::filesystem::temp_directory_path() / "multibond-dot-XXXXXX").string();
  const int log_fd = mkstemp(log.data());
  if (log_fd < 0) return fail(fmt::format("cannot create a temporary file for dot's messages: {}", std::strerror(errno)));
  close(log_fd);
  const std::string failure = RunProcess(argv, "", log);
  std::remove(log.c_str());
  if (!failure.empty()) {
    if (failure.find("not installed") != std::string::npos)
      return fail("cannot run 'dot': Graphviz is not installed (or not on PATH)");
    return fail(fmt::format("'dot {}' failed on '{}': {}", formats, MessageText(dot_path), MessageText(failure)));
  }
  return true;
}

bool RenderWithGraphviz(const std::string& dot_path, const std::string& out_path, const std::string& format,
                        std::string* error) {
  return RenderWithGraphviz(dot_path, {{format, out_path}}, error);
}

}  // namespace multibond
