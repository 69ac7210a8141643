// Prints the validation summary of a differential run: differential_report RESULTS_DIR
// (the README's main command runs it after `multibond run examples/differential.yaml`).

#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "differential_checks.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: differential_report RESULTS_DIR\n");
    return 64;
  }
  const std::string dir = argv[1];
  try {
    const multibond::ResultsTable t = multibond::ReadResults(dir + "/results.csv");
    std::ifstream in(dir + "/run.json");
    const auto run = nlohmann::json::parse(in);
    std::printf("Differential of the paper (docs/differential.md), t = %.3g s\n", t.rows.back()[0]);
    std::printf("  solver %s, rtol %.1e: %ld steps, %ld right-hand sides, %.3f s wall (%s)\n",
                run["options"]["solver"].get<std::string>().c_str(), run["options"]["rtol"].get<double>(),
                run["solver_stats"]["steps"].get<long>(), run["solver_stats"]["rhs_evals"].get<long>(),
                run["wall_seconds"].get<double>(), run.value("rhs_engine", std::string("?")).c_str());
    int failed = 0;
    for (const auto& c : differential::Checks(t)) {
      std::printf("  %-48s %16.9g %-6s expected %-12.6g %s\n", c.what.c_str(), c.value, c.unit.c_str(), c.expected,
                  c.ok() ? "ok" : "OUT OF TOLERANCE");
      failed += !c.ok();
    }
    std::printf("  energy: work %.9g J = stored %.9g J + dissipated %.9g J (residual %.2e)\n", t.Last("energy.work"),
                t.Last("energy.kinetic") + t.Last("energy.potential"), t.Last("energy.dissipated"), t.Last("energy.residual"));
    std::printf("%s\n", failed ? "some values are out of tolerance" : "every value within tolerance");
    return failed ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
