#include "multibond/io/yaml_bounds.h"

#include <cstdint>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/anchor.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include "multibond/io/diagnostic_codes.h"

namespace multibond {

namespace {

/// Thrown by the handler to stop the parser at the first problem (already in the sink).
struct Stop {};

class BoundsHandler : public YAML::EventHandler {
 public:
  BoundsHandler(const std::string& file, std::size_t text_size, const InputLimits& limits, DiagnosticSink& sink)
      : file_(file), limits_(limits), sink_(sink), max_written_(2 * static_cast<std::uint64_t>(text_size) + 16) {}

  void OnDocumentStart(const YAML::Mark&) override {
    anchors_.assign(1, Anchor{});  // anchor ids count from 1 in each document
    open_.clear();
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override { Leaf(mark, anchor); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor, const std::string&) override { Leaf(mark, anchor); }
  void OnAnchor(const YAML::Mark&, const std::string& name) override { pending_name_ = name; }

  void OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) override {
    if (anchor >= anchors_.size()) return;  // yaml-cpp has refused an unknown anchor already
    const Anchor& a = anchors_[anchor];
    if (a.open) {
      Diagnostic d;
      d.where = Where(mark);
      d.code = codes::kYamlSelfAlias;
      d.message = fmt::format("the alias '*{}' stands for the node anchored '&{}' (at {}), which contains this alias: the node "
                              "would contain itself without end", a.name, a.name, a.where.ToString());
      d.hint = "an alias may only refer to a node that is complete before it";
      sink_.Add(d);
      throw Stop{};
    }
    Count(mark, a.size);
  }

  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor, YAML::EmitterStyle::value) override { Open(mark, anchor); }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor, YAML::EmitterStyle::value) override { Open(mark, anchor); }
  void OnMapEnd() override { Close(); }

 private:
  struct Anchor {
    std::string name;
    SourceLocation where;
    std::uint64_t size = 0;  ///< nodes of the anchored node, its aliases expanded
    bool open = false;       ///< the anchored node has started and not ended
  };
  struct Frame {
    YAML::anchor_t anchor;
    std::uint64_t nodes_before;
  };

  SourceLocation Where(const YAML::Mark& m) const { return m.line < 0 ? SourceLocation{file_, 0, 0} : SourceLocation{file_, m.line + 1, m.column + 1}; }

  /// Records the anchor a node starts (yaml-cpp numbers anchors 1, 2, ... in the order defined).
  void Define(const YAML::Mark& mark, YAML::anchor_t anchor, bool open) {
    if (anchor == YAML::NullAnchor) return;
    if (anchors_.size() <= anchor) anchors_.resize(anchor + 1);
    anchors_[anchor] = Anchor{pending_name_, Where(mark), 0, open};
  }

  void Count(const YAML::Mark& mark, std::uint64_t n) {
    nodes_ += n;
    if (nodes_ <= limits_.yaml_nodes) return;
    Diagnostic d;
    d.where = Where(mark);
    d.code = codes::kLimitYamlNodes;
    d.message = fmt::format("limit 'yaml-nodes' exceeded: the file holds more than {} YAML nodes (each alias counted as the nodes "
                            "it stands for)", limits_.yaml_nodes);
    d.hint = RaiseLimitHint("yaml-nodes", limits_.yaml_nodes);
    sink_.Add(d);
    throw Stop{};
  }

  void Leaf(const YAML::Mark& mark, YAML::anchor_t anchor) {
    Define(mark, anchor, false);
    if (anchor != YAML::NullAnchor) anchors_[anchor].size = 1;
    Written(mark);
    Count(mark, 1);
  }

  /// A node written in the file (not an alias) takes at least half a character of it ("a:" is a
  /// key and a null): more means yaml-cpp is producing nodes without reading (seen on malformed
  /// flow collections: a million nulls from 706 bytes), and it is stopped at once.
  void Written(const YAML::Mark& mark) {
    if (++written_ <= max_written_) return;
    Diagnostic d;
    d.where = Where(mark);
    d.code = codes::kYamlSyntax;
    d.message = "the YAML here cannot be read: the parser produced more nodes than the file has characters";
    d.hint = "check the brackets, braces and commas of the flow collections ([...] and {...}) around this place";
    sink_.Add(d);
    throw Stop{};
  }

  void Open(const YAML::Mark& mark, YAML::anchor_t anchor) {
    Define(mark, anchor, true);
    Written(mark);
    open_.push_back({anchor, nodes_});
    Count(mark, 1);
    if (open_.size() <= limits_.depth) return;
    Diagnostic d;
    d.where = Where(mark);
    d.code = codes::kLimitDepth;
    d.message = fmt::format("limit 'depth' exceeded: YAML lists and mappings nested more than {} deep", limits_.depth);
    d.hint = RaiseLimitHint("depth", limits_.depth);
    sink_.Add(d);
    throw Stop{};
  }

  void Close() {
    if (open_.empty()) return;
    const Frame f = open_.back();
    open_.pop_back();
    if (f.anchor != YAML::NullAnchor && f.anchor < anchors_.size()) {
      anchors_[f.anchor].open = false;
      anchors_[f.anchor].size = nodes_ - f.nodes_before;
    }
  }

  const std::string& file_;
  const InputLimits& limits_;
  DiagnosticSink& sink_;
  std::vector<Anchor> anchors_ = std::vector<Anchor>(1);
  std::vector<Frame> open_;
  std::string pending_name_;
  std::uint64_t nodes_ = 0;
  std::uint64_t written_ = 0;  ///< nodes written in the file (aliases not counted)
  std::uint64_t max_written_;
};

}  // namespace

bool CheckYamlBounds(const std::string& text, const std::string& file, const InputLimits& limits, DiagnosticSink& sink) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  BoundsHandler handler(file, text.size(), limits, sink);
  try {
    while (parser.HandleNextDocument(handler)) {
    }
  } catch (const Stop&) {
    return false;
  }
  return true;
}

}  // namespace multibond
