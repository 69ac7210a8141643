#pragma once
/// \file
/// Drawing a bond graph with Graphviz: the DOT text, and running `dot` on it.
///
/// Elements are plain-text nodes ("I: mass", junctions "1"/"0" with their name in small type),
/// bonds are edges with a half-arrow at the head and, when causality is known, the causal
/// stroke as a `tee` at the end where it sits. Storage elements in derivative causality are red.

#include <map>
#include <string>
#include <vector>

#include "multibond/causality/causality.h"
#include "multibond/core/graph.h"
#include "multibond/core/structure.h"

namespace multibond {

/// Options of MakeDot.
struct DotOptions {
  /// Put elements whose names share a dotted prefix ("A.w", "A.J") in a cluster ("A"); nested
  /// prefixes ("A.B.x") give nested clusters.
  bool group_by_prefix = true;
  /// Draw cluster `key` inside cluster `value`, e.g. a joint's elements inside its child link's
  /// ({"G_bearing", "G"}), so that a mechanism is drawn grouped by link. An entry is ignored
  /// unless both are clusters and the nesting makes no cycle.
  std::map<std::string, std::string> nest;
  /// Label bonds with their names (besides their dimension). The tooltip has the name either
  /// way; large graphs read better without.
  bool bond_names = true;
};

/// Graphviz DOT of a bond graph. `causality` may be null (no strokes) — a graph with causality
/// problems must still be drawable; `structure` may be null (dimensions unknown).
/// The output is deterministic: nodes in element order, edges in bond order.
std::string MakeDot(const BondGraph& g, const Structure* structure, const CausalAssignment* causality,
                    const DotOptions& options = {});

/// One output of a Graphviz run: its format (e.g. "svg", "png", "json") and file.
struct GraphvizOutput {
  std::string format, path;
};

/// Runs `dot -T<format> -o <path> ... <dot_path>` once for every output (no shell involved): the
/// graph is laid out once and written in each format. Returns false with a message in `error` (if
/// non-null) when `dot` is missing or fails, or a format is not a plain word.
bool RenderWithGraphviz(const std::string& dot_path, const std::vector<GraphvizOutput>& outputs, std::string* error);

/// Runs `dot -T<format> -o <out_path> <dot_path>` (no shell involved). `format` is e.g. "svg" or
/// "png". Returns false with a message in `error` (if non-null) when `dot` is missing or fails.
bool RenderWithGraphviz(const std::string& dot_path, const std::string& out_path, const std::string& format,
                        std::string* error);

}  // namespace multibond
