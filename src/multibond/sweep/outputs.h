#pragma once
/// \file
/// What a sweep leaves in its folder (docs/sweeps.md): sweep.csv, one row per run in run order
/// (run, the swept parameters, status, the kept quantities, reason; numbers with round-trip
/// precision, so the table is the same to the last bit whoever ran which run); sweep.json (the
/// study, seed, counts, versions, timing); for sampled studies the sensitivity ranking
/// (sensitivity.csv: Spearman's rank correlation of each kept quantity with each parameter, the
/// parameters ranked by its magnitude); and plots/<quantity>_vs_<parameter>.svg (gnuplot). Every
/// file is published complete or not at all (io/atomic_file.h).

#include <string>
#include <vector>

#include "multibond/sweep/runner.h"
#include "multibond/sweep/study.h"

namespace multibond::sweep {

/// sweep.csv's text.
std::string SweepCsv(const Study& study, const std::vector<std::vector<double>>& design, const std::vector<RunResult>& results);

struct Sensitivity {
  std::string quantity, parameter;
  double spearman = 0.0;  ///< NaN when it cannot be told (fewer than 3 runs ok, a constant)
  int rank = 0;           ///< 1 = the parameter that moves the quantity most
};
/// For each kept quantity, each parameter's rank correlation with it over the runs that
/// succeeded (ties get their mean rank), ranked by magnitude.
std::vector<Sensitivity> SensitivityRanking(const Study& study, const std::vector<std::vector<double>>& design,
                                            const std::vector<RunResult>& results);
/// Spearman's rank correlation of x and y (NaN for fewer than 3 pairs or a constant).
double Spearman(const std::vector<double>& x, const std::vector<double>& y);

struct SweepFacts {
  std::string model_sha256, study_hash;
  long runs = 0, failed = 0, resumed = 0;
  int ranks = 1, threads = 1;
  double wall_seconds = 0.0;
  RunTiming timing;
  std::string rhs_engine;
};
std::string SweepJson(const Study& study, const SweepFacts& facts, const std::vector<Sensitivity>& sensitivity);

/// Writes sweep.csv, sweep.json, sensitivity.csv (sampled studies) and the plots into `dir`.
/// Returns the plots that could not be made, with why (gnuplot missing, failed): not an error.
std::vector<std::string> WriteOutputs(const std::string& dir, const Study& study, const std::vector<std::vector<double>>& design,
                                      const std::vector<RunResult>& results, const SweepFacts& facts);

}  // namespace multibond::sweep
