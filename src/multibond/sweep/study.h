#pragma once
/// \file
/// A study (docs/sweeps.md): which model, which of its top-level parameters vary and how (a grid,
/// a list, or distributions sampled by Monte Carlo or a Latin hypercube, from a seed), what to
/// keep of each run, and the run's settings. Read from a study file (ReadStudyFile) or built from
/// the command line (AddAxisSpec, AddKeepSpec); every problem is a located diagnostic with a
/// `sweep.*` code (core/diagnostic_codes.h), all of them thrown together as one ModelError before
/// any run starts.

#include <cstdint>
#include <optional>
#include <cmath>
#include <string>
#include <vector>

#include "multibond/core/error.h"
#include "multibond/io/limits.h"

namespace multibond::sweep {

/// One swept parameter of the model.
struct Axis {
  enum class Kind { kGrid, kList, kDistribution };
  enum class Scale { kLinear, kLog };
  enum class Distribution { kUniform, kLogUniform, kNormal, kLogNormal };
  std::string name;  ///< a top-level parameter of the model
  SourceLocation where;
  Kind kind = Kind::kGrid;
  // kGrid: `count` values from `from` to `to` (both included), evenly spaced on `scale`.
  double from = 0.0, to = 0.0;
  int count = 0;
  Scale scale = Scale::kLinear;
  std::vector<double> values;  ///< kList
  // kDistribution: uniform/loguniform on [a, b]; normal/lognormal with mean a, standard deviation b
  // (lognormal: of the logarithm).
  Distribution distribution = Distribution::kUniform;
  double a = 0.0, b = 0.0;
  /// A number of the axis was refused as it was read (not a number, NaN, a count beyond the
  /// limit): CheckAxis says nothing more of it (no "range 1 to 0" from a value taken as 0).
  bool refused = false;
};

/// What is kept of each run: `take` of the expression `of` (core/expression's grammar) over the
/// run's result columns.
struct Keep {
  enum class Take { kFinal, kMax, kMin, kMean, kRms, kSettlingTime, kCrossingTime, kEventTime };
  std::string name;  ///< the column of sweep.csv
  SourceLocation where;       ///< of the name
  SourceLocation expression;  ///< of `of`'s first character
  Take take = Take::kFinal;
  std::string of;           ///< the expression (kEventTime: the event kind, "" = any)
  double band = 0.02;       ///< kSettlingTime: the relative band around the final value
  double level = 0.0;       ///< kCrossingTime: the level crossed
  std::string element;      ///< kEventTime: only events of this element ("" = any)
  /// The window [from, to] (s) of the run the quantity is taken over: the output samples (and,
  /// for kEventTime, the events) in it; the whole run by default.
  double from = -HUGE_VAL, to = HUGE_VAL;
  bool windowed() const { return from != -HUGE_VAL || to != HUGE_VAL; }
};

struct Study {
  std::string file;  ///< the study file ("" when given on the command line)
  std::string name = "sweep";
  std::string model;  ///< the model file, resolved against the study file's folder
  SourceLocation model_where;
  enum class Method { kGrid, kMonteCarlo, kLatinHypercube };
  Method method = Method::kGrid;
  long samples = 0;  ///< Monte Carlo, Latin hypercube
  std::uint64_t seed = 0;
  bool seed_given = false;
  std::vector<Axis> axes;
  std::vector<Keep> keep;
  /// Parameters fixed for every run (`set:`, --set), as the loader takes them.
  std::vector<std::pair<std::string, std::string>> set;
  std::vector<SourceLocation> set_where;  ///< of each name of `set`
  /// Run settings over the model file's `simulation:`.
  std::optional<double> t_end, dt, rtol, atol;
  std::optional<std::string> solver;
  bool keep_results = false;  ///< write each run's full results (runs/run-<index>.csv)
};

/// Where a study given on the command line is said to be in messages.
inline constexpr const char* kCommandLine = "<command line>";

/// The study file `path` (docs/sweeps.md). Throws ModelError (every problem found, located).
Study ReadStudyFile(const std::string& path, const InputLimits& limits = {});
/// The same from text; `file` names it in messages and relative model paths are resolved
/// against its folder. With `sink`, problems are added to it instead of thrown (so that the
/// checks against the model can be reported with them), and CheckStudy is left to the caller
/// (after the command line's additions).
Study ReadStudyString(const std::string& text, const std::string& file, DiagnosticSink* sink = nullptr);
/// Whether the YAML text is a study (it has `sweep:` or `keep:`) rather than a model.
bool LooksLikeStudy(const std::string& text);

/// --grid NAME=FROM:TO[:lin|log]:COUNT, --list NAME=V1,V2,..., --sample NAME=DIST:A:B: one axis
/// more. Problems go to `sink`, located at the option's text (file kCommandLine, column in it).
void AddAxisSpec(Study& study, const std::string& option, const std::string& spec, DiagnosticSink& sink);
/// --keep NAME=TAKE:EXPRESSION (TAKE one of final, max, min, mean, rms, settling_time,
/// crossing_time@LEVEL, event_time) or NAME=EXPRESSION (its final value).
void AddKeepSpec(Study& study, const std::string& spec, DiagnosticSink& sink);
/// Checks what needs no model: a study with nothing swept or kept, a method that does not fit
/// the axes, samples and seed. Problems go to `sink`.
void CheckStudy(const Study& study, DiagnosticSink& sink);

/// A study as a front end gives it: a study file (or a model file, the study then given by the
/// rest), and additions in the command line's forms (--grid, --list, --sample, --keep, ...).
struct StudyArguments {
  std::string path;  ///< a study file, or a model file
  std::vector<std::string> grids, lists, samples_of, keeps;
  std::optional<long> samples;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> method;  ///< grid, monte_carlo, latin_hypercube
  std::vector<std::pair<std::string, std::string>> set;  ///< parameters fixed for every run, after the file's
  bool results = false;
};
/// The study of `a`, checked (CheckStudy); its problems are added to `sink` (not thrown, so that
/// the checks against the model can follow). Reads the model's text into `model_text`; a study
/// file or model that cannot be read throws ModelError (io.*), as does a study without a model.
Study StudyFromArguments(const StudyArguments& a, const InputLimits& limits, DiagnosticSink& sink, std::string& model_text);

/// The names of Keep::Take as written (final, max, ...).
const char* TakeName(Keep::Take t);
/// A canonical text of everything that decides the runs' numbers (for the journal's hash, and
/// sweep.json): two studies with the same text give the same table.
std::string CanonicalText(const Study& study);

}  // namespace multibond::sweep
