#pragma once
/// \file
/// The model file of `plot --model` and `view --model`, read once for everything drawn from it:
/// the bond graph figure (png, svg), the page's bond graph (Graphviz's layout) and its 3D view
/// (the scene). The model is loaded, its structure analysed and its causality assigned once, and
/// its bond graph written as DOT once; every drawing starts from that one text.

#include <optional>
#include <string>

#include "multibond/io/dot_writer.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_loader.h"

namespace multibond {

/// Drawing options for a mechanism's bond graph, grouped by link: each joint's and drive's
/// elements inside its child link's cluster, each gear mesh inside its gear `a`'s, each relative
/// velocity "X~Y" inside X's; bonds labelled by dimension only. The links come from the model
/// file's mechanism sections (bodies, joints, gears, drives); a model without them gets the plain
/// grouping by name prefix.
DotOptions LinkGrouping(const LoadedModel& model);

/// A model file as plot draws it.
struct PlotModel {
  /// Loads `path` ("" for none) within `limits`. Never throws for what the file holds: a model
  /// that does not load is `given()` without `loaded`.
  static PlotModel Read(const std::string& path, const InputLimits& limits);

  std::string path;                   ///< as the user gave it; "" when none was given
  std::optional<LoadedModel> loaded;  ///< empty when none was given or it does not load
  /// The bond graph with causal strokes, grouped by link (MakeDot, LinkGrouping); "" when the
  /// model has structural errors (it is drawn then by 'multibond graph', not by plot).
  std::string dot;

  bool given() const { return !path.empty(); }
};

}  // namespace multibond
