// Result file benchmarks: BM_WriteResults/<format>/<compress>, wall time to write 5,001 rows x 200 columns
// (a 5 s run at dt = 1 ms of a model with 200 columns) as `multibond run --format <format>` does:
// every row passed on as the run computes it, then the file finished (synced, hashed) and
// published (replacing the previous iteration's file, as a rerun does). The values are smooth signals with full mantissas, as results are.
// Target: mat and h5 take less than a tenth of csv's time.
// Run: build/release/bench/multibond_bench --benchmark_filter=WriteResults

#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "../tests/support/temp_dir.h"
#include "multibond/io/results_files.h"

namespace mb = multibond;

namespace {

constexpr int kRows = 5001, kColumns = 200;

void BM_WriteResults(benchmark::State& state) {
  const auto format = static_cast<mb::ResultFormat>(state.range(0));
  const bool compress = state.range(1) != 0;
  state.SetLabel(std::string(mb::ResultFormatName(format)) + (compress ? " compressed" : ""));
  std::vector<mb::Column> columns = {{"time", "s"}};
  for (int c = 1; c < kColumns; ++c) columns.push_back({"body" + std::to_string(c / 3) + ".omega." + "xyz"[c % 3], "rad/s"});
  std::vector<std::vector<double>> rows(kRows, std::vector<double>(kColumns));
  for (int r = 0; r < kRows; ++r) {
    const double t = 1e-3 * r;
    rows[r][0] = t;
    for (int c = 1; c < kColumns; ++c) rows[r][c] = std::exp(-0.1 * c * t) * std::sin((1.0 + 0.37 * c) * t + c);
  }
  const nlohmann::json record = {{"model", {{"file", "bench.yaml"}, {"name", "bench"}, {"sha256", std::string(64, '0')}}},
                                 {"status", "ok"}, {"options", {{"solver", "bdf"}, {"rtol", 1e-8}, {"atol", 1e-10}}}};
  mb::RunSummary summary;
  std::uint64_t bytes = 0;
  const mb::testing::TempDir dir("multibond-bench");  // each iteration replaces the file, as a rerun does
  for (auto _ : state) {
    mb::ResultsFiles files(dir.path().string(), {format}, kRows, compress);
    files.OnStart(columns);
    for (const std::vector<double>& row : rows) files.OnSample(row);
    files.OnFinish(summary);
    files.Finish(record);
    files.Publish();
    bytes = files.FilesRecord()[0]["bytes"].get<std::uint64_t>();
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_WriteResults)
    ->Args({static_cast<int>(mb::ResultFormat::kCsv), 0})
    ->Args({static_cast<int>(mb::ResultFormat::kMat), 0})
    ->Args({static_cast<int>(mb::ResultFormat::kH5), 0})
    ->Args({static_cast<int>(mb::ResultFormat::kMat), 1})
    ->Args({static_cast<int>(mb::ResultFormat::kH5), 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace
