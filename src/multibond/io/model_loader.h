#pragma once
/// \file
/// Reads a multibond model file (YAML, see docs/model-format.md) into a BondGraph. Every problem
/// found is collected and thrown together as one ModelError, each with file:line:column, the
/// element's name, what is wrong and a hint.

#include <optional>
#include <string>

#include <memory>

#include "multibond/compile/compiled_model.h"
#include "multibond/io/did_you_mean.h"
#include "multibond/io/limits.h"
#include "multibond/io/model_parameters.h"
#include "multibond/mech/mechanism.h"
#include "multibond/solve/integrator.h"

namespace YAML {
class Node;
}

namespace multibond {

/// Run settings a model file may carry (the command line overrides them).
struct SimulationDefaults {
  std::optional<double> t_end, dt, rtol, atol, step, max_step;
  std::optional<std::string> solver;
  std::optional<std::string> coordinates;  ///< "joint" or "inertial" (RunOptions::joint_coordinates)
  /// "model" (the elements' and states' initial values) or "steady" (the steady state found from
  /// them at the start, the sources held: RunOptions::initial_state, `run --steady`).
  std::optional<std::string> initial;
  /// Events: RunOptions::event_rest_time (>= 0) and RunOptions::max_events_per_second (> 0).
  std::optional<double> event_rest_time, max_events_per_second;
};

struct LoadedModel {
  BondGraph graph;
  CompileOptions compile;
  SimulationDefaults simulation;
  std::string file;  ///< path as given ("<string>" for text)
  std::string text;  ///< the file's content, for hashing and provenance
  std::vector<Diagnostic> warnings;  ///< problems that do not stop the model (e.g. a deflected coupling)
  std::shared_ptr<const mech::Mechanism> mechanism;  ///< the mechanism sections, if any
  /// The top-level parameters with their final values, in the order of the file.
  std::vector<ModelParameter> parameters;
};

/// Adds to each causality diagnostic about a mechanism's elements a line that names the parts on
/// its causal path ("in mechanism terms: drive 'motor' -> body 'G' ..."), so that a user who
/// wrote bodies and joints reads the problem in those terms.
void ExplainInMechanismTerms(const mech::Mechanism& m, std::vector<Diagnostic>& diagnostics);

/// Reads a model file. It must be a regular file (a directory, device or FIFO is refused with a
/// diagnostic whose code starts with "io.", as is a file that cannot be opened); at most
/// limits.file_bytes are read. Every bound of `limits` exceeded is a located diagnostic with the
/// code "limit.<name>" (see InputLimits), bytes that are not UTF-8 one with "text.encoding".
/// `parameters` replace the values of the file's top-level parameters (--set NAME=VALUE); one
/// that names no parameter of the file, or whose value does not read, is the caller's mistake:
/// std::invalid_argument (with a did-you-mean).
LoadedModel LoadModelFile(const std::string& path, const InputLimits& limits = {}, const std::vector<ParameterOverride>& parameters = {});
/// The same for a model's text; `file` names it in diagnostics.
LoadedModel LoadModelString(const std::string& yaml, const std::string& file = "<string>", const InputLimits& limits = {},
                            const std::vector<ParameterOverride>& parameters = {});

/// A model's text parsed once (its YAML read and checked within the limits), to be loaded many
/// times with other parameter values without parsing the text again: a sweep's runs. Load is the
/// same as LoadModelString(text, file, limits, parameters). yaml-cpp's nodes may not be read from
/// two threads at once: each thread keeps its own ParsedModel.
class ParsedModel {
 public:
  /// Throws ModelError for a text that does not parse (as LoadModelString).
  ParsedModel(std::string text, std::string file, const InputLimits& limits);
  ~ParsedModel();
  ParsedModel(const ParsedModel&) = delete;
  ParsedModel& operator=(const ParsedModel&) = delete;
  LoadedModel Load(const std::vector<ParameterOverride>& parameters = {}) const;

 private:
  std::string file_, text_;
  InputLimits limits_;
  std::unique_ptr<YAML::Node> root_;
};

}  // namespace multibond
