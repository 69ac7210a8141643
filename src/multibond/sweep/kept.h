#pragma once
/// \file
/// The quantities kept of each run (Keep): each an expression of the run's result columns
/// (core/expression's grammar, compiled once per sweep into a flat program over a result row,
/// compile/expr_program.h) and a way to take it: its final value, maximum, minimum, time mean,
/// RMS, settling time into a band around its final value, the first time it crosses a level, or
/// the time of the first event of a kind; over the whole run or a window of it (the samples and
/// events from Keep::from to Keep::to). An observer computes them while the run goes, without
/// keeping its rows; one observer per thread, reused from run to run.

#include <string>
#include <vector>

#include "multibond/compile/expr_program.h"
#include "multibond/sim/simulator.h"
#include "multibond/sweep/study.h"

namespace multibond::sweep {

class KeptQuantities {
 public:
  /// Compiles the study's kept quantities over `columns` (the result columns of the model, time
  /// first). A name that is no column is looked up in `all_columns` (every effort and flow): when
  /// found there, needs_all_variables() is set. Problems (an expression that does not read, a
  /// name of no column, with a did-you-mean) go to `sink` with the code sweep.keep, located at
  /// the character of the expression.
  KeptQuantities(const std::vector<Keep>& keep, const std::vector<std::string>& columns, const std::vector<std::string>& all_columns,
                 DiagnosticSink& sink);
  bool needs_all_variables() const { return all_variables_; }
  const std::vector<Keep>& keep() const { return keep_; }
  const std::vector<expr::Program>& programs() const { return programs_; }
  /// The columns the programs read (as compiled).
  const std::vector<std::string>& columns() const { return columns_; }

 private:
  std::vector<Keep> keep_;
  std::vector<expr::Program> programs_;
  std::vector<std::string> columns_;
  bool all_variables_ = false;
};

/// Computes the kept quantities of one run from its samples and events.
class KeptObserver : public Observer {
 public:
  explicit KeptObserver(const KeptQuantities& q);
  /// Ready for a new run (keeps its buffers).
  void Reset();
  void OnStart(const std::vector<Column>& columns) override;
  void OnSample(const std::vector<double>& row) override;
  void OnEvent(const EventRecord& event) override;
  void OnFinish(const RunSummary& summary) override { summary_ = summary; }
  /// The values, one per kept quantity (NaN: never reached, e.g. a level never crossed).
  std::vector<double> Values() const;
  const RunSummary& summary() const { return summary_; }
  /// "" when the run's columns were those compiled against, else what differs.
  const std::string& column_problem() const { return column_problem_; }

 private:
  struct Accumulator {
    double last = 0.0, max = 0.0, min = 0.0, integral = 0.0, integral_sq = 0.0, crossing = 0.0, event = 0.0;
    double prev_t = 0.0, prev_v = 0.0, first_t = 0.0;
    long samples = 0;  ///< in the window
    std::vector<double> t, v;  ///< settling time: the series (its capacity kept across runs)
  };
  const KeptQuantities& q_;
  std::vector<Accumulator> acc_;
  RunSummary summary_;
  std::string column_problem_;
};

/// The settling time of the series (t, v) into the band |v - v_final| <= band * |v_final| (of the
/// largest |v| when the final value is 0): the time after which it stays in the band, found by
/// interpolation on the last interval that left it; t.front() when it never left.
double SettlingTime(const std::vector<double>& t, const std::vector<double>& v, double band);

}  // namespace multibond::sweep
