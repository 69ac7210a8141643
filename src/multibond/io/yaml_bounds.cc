#include "multibond/io/yaml_bounds.h"

#include <cstdint>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/anchor.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/node/detail/memory.h>
#include <yaml-cpp/node/detail/node.h>
#include <yaml-cpp/yaml.h>

#include "multibond/core/interrupt.h"
#include "multibond/core/diagnostic_codes.h"

namespace multibond {
namespace {
/// Names the one specialization of YAML::as_if below (a type of this file only).
struct BuiltTree {};
}  // namespace
}  // namespace multibond

/// yaml-cpp makes the YAML::Node of a built tree's root with a private constructor, which its own
/// builder (behind YAML::Load, not installed) and the class template `as_if` may call: this
/// specialization of as_if for a type of this file does only that, for the builder below.
namespace YAML {
template <>
struct as_if<multibond::BuiltTree, multibond::BuiltTree> {
  static Node Root(detail::node& root, const detail::shared_memory_holder& memory) { return Node(root, memory); }
};
}  // namespace YAML

namespace multibond {

namespace {

/// Thrown by the handler to stop the parser at the first problem (already in the sink).
struct Stop {};

/// Checks each event against the bounds before it is used; with `build`, makes the document's
/// tree of them as yaml-cpp's own builder does (YAML::LoadAll): a node per event with its mark
/// (tag and style for collections and scalars), an alias the very node its anchor names, each
/// finished node appended to the list or, alternately as key and value, to the mapping open
/// around it.
class BoundsHandler : public YAML::EventHandler {
 public:
  BoundsHandler(const std::string& file, std::size_t text_size, const InputLimits& limits, DiagnosticSink& sink, bool build)
      : file_(file), limits_(limits), sink_(sink), max_written_(2 * static_cast<std::uint64_t>(text_size) + 16),
        memory_(build ? std::make_shared<YAML::detail::memory_holder>() : nullptr) {}

  /// The last document's tree (a default Node for an empty document or without `build`).
  YAML::Node Root() const { return root_ ? YAML::as_if<BuiltTree, BuiltTree>::Root(*root_, memory_) : YAML::Node(); }

  void OnDocumentStart(const YAML::Mark&) override {
    anchors_.assign(1, Anchor{});  // anchor ids count from 1 in each document
    open_.clear();
    if (memory_) memory_ = std::make_shared<YAML::detail::memory_holder>();  // each document its own tree
    root_ = nullptr;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override {
    Leaf(mark, anchor);
    if (!memory_) return;
    YAML::detail::node& n = Make(mark, anchor);
    n.set_null();
    Finish(n);
  }
  void OnScalar(const YAML::Mark& mark, const std::string& tag, YAML::anchor_t anchor, const std::string& value) override {
    Leaf(mark, anchor);
    if (!memory_) return;
    YAML::detail::node& n = Make(mark, anchor);
    n.set_scalar(value);
    n.set_tag(tag);
    Finish(n);
  }
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
    if (memory_ && a.node) Finish(*a.node);
  }

  void OnSequenceStart(const YAML::Mark& mark, const std::string& tag, YAML::anchor_t anchor, YAML::EmitterStyle::value style) override {
    Open(mark, anchor);
    if (memory_) Collection(mark, tag, anchor, style, YAML::NodeType::Sequence);
  }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark& mark, const std::string& tag, YAML::anchor_t anchor, YAML::EmitterStyle::value style) override {
    Open(mark, anchor);
    if (memory_) Collection(mark, tag, anchor, style, YAML::NodeType::Map);
  }
  void OnMapEnd() override { Close(); }

 private:
  struct Anchor {
    std::string name;
    SourceLocation where;
    std::uint64_t size = 0;  ///< nodes of the anchored node, its aliases expanded
    bool open = false;       ///< the anchored node has started and not ended
    YAML::detail::node* node = nullptr;  ///< the anchored node (when building)
  };
  struct Frame {
    YAML::anchor_t anchor;
    std::uint64_t nodes_before;
    YAML::detail::node* collection = nullptr;  ///< the list or mapping (when building)
    YAML::detail::node* key = nullptr;         ///< a mapping's key waiting for its value
  };

  /// A new node of the tree at `mark`, the node of `anchor` if it has one.
  YAML::detail::node& Make(const YAML::Mark& mark, YAML::anchor_t anchor) {
    YAML::detail::node& n = memory_->create_node();
    n.set_mark(mark);
    if (anchor != YAML::NullAnchor) anchors_[anchor].node = &n;  // Define has made the entry
    return n;
  }

  /// The list or mapping that Open has just pushed (its frame on top of open_).
  void Collection(const YAML::Mark& mark, const std::string& tag, YAML::anchor_t anchor, YAML::EmitterStyle::value style,
                  YAML::NodeType::value type) {
    YAML::detail::node& n = Make(mark, anchor);
    n.set_type(type);
    n.set_tag(tag);
    n.set_style(style);
    open_.back().collection = &n;
  }

  /// `n` is complete: the document's root, or the next item of the collection open around it.
  void Finish(YAML::detail::node& n) {
    if (open_.empty()) {
      root_ = &n;
      return;
    }
    Frame& f = open_.back();
    if (f.collection->type() == YAML::NodeType::Sequence) {
      f.collection->push_back(n, memory_);
    } else if (!f.key) {
      f.key = &n;
    } else {
      f.collection->insert(*f.key, n, memory_);
      f.key = nullptr;
    }
  }

  SourceLocation Where(const YAML::Mark& m) const { return m.line < 0 ? SourceLocation{file_, 0, 0} : SourceLocation{file_, m.line + 1, m.column + 1}; }

  /// Records the anchor a node starts (yaml-cpp numbers anchors 1, 2, ... in the order defined).
  void Define(const YAML::Mark& mark, YAML::anchor_t anchor, bool open) {
    if (anchor == YAML::NullAnchor) return;
    if (anchors_.size() <= anchor) anchors_.resize(anchor + 1);
    anchors_[anchor] = Anchor{pending_name_, Where(mark), 0, open, nullptr};
  }

  void Count(const YAML::Mark& mark, std::uint64_t n) {
    // A large file takes seconds to parse: a stop asked for meanwhile ends it (Interrupted goes
    // through the parser as Stop does).
    if ((++events_ & 4095) == 0) ThrowIfStopRequested("loading the model");
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
    open_.push_back({anchor, nodes_, nullptr, nullptr});
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
    if (f.collection) Finish(*f.collection);
  }

  const std::string& file_;
  const InputLimits& limits_;
  DiagnosticSink& sink_;
  std::vector<Anchor> anchors_ = std::vector<Anchor>(1);
  std::vector<Frame> open_;
  std::string pending_name_;
  std::uint64_t nodes_ = 0;
  std::uint64_t events_ = 0;  ///< events seen (for the stop check)
  std::uint64_t written_ = 0;  ///< nodes written in the file (aliases not counted)
  std::uint64_t max_written_;
  YAML::detail::shared_memory_holder memory_;  ///< the nodes of the document's tree; null: check only
  YAML::detail::node* root_ = nullptr;
};

}  // namespace

bool CheckYamlBounds(const std::string& text, const std::string& file, const InputLimits& limits, DiagnosticSink& sink) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  BoundsHandler handler(file, text.size(), limits, sink, /*build=*/false);
  try {
    while (parser.HandleNextDocument(handler)) {
    }
  } catch (const Stop&) {
    return false;
  }
  return true;
}

std::optional<std::vector<YAML::Node>> LoadYamlBounded(const std::string& text, const std::string& file, const InputLimits& limits,
                                                       DiagnosticSink& sink) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  BoundsHandler handler(file, text.size(), limits, sink, /*build=*/true);
  std::vector<YAML::Node> documents;
  try {
    while (parser.HandleNextDocument(handler)) documents.push_back(handler.Root());
  } catch (const Stop&) {
    return std::nullopt;
  }
  return documents;
}

}  // namespace multibond
