// `multibond run --format`: results.csv, results.mat and results.h5 of one run hold the same
// numbers, to the last bit (the CSV's shortest round-trip form is exact), read as users read them:
// SciPy and h5py (Debian's python3) and Octave; run.json lists every file with its size and hash;
// an unknown format writes nothing; the files of a failed run are kept in every format.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/external_readers.h"
#include "multibond/core/sha256.h"
#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using multibond::testing::CliResult;
using multibond::testing::ListNames;
using multibond::testing::ReadFile;
using multibond::testing::RunCli;
using multibond::testing::TempDir;

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

/// Reads results.csv (Python's float() reads the shortest round-trip form exactly) and compares it
/// with results.mat (SciPy) and results.h5 (h5py), bit for bit. Prints one JSON object.
constexpr const char* kCompare = R"PY(
import csv, json, re, sys
import numpy as np
import scipy.io, h5py
folder = sys.argv[1]
with open(folder + '/results.csv', newline='') as f:
    rows = list(csv.reader(f))
header = [re.fullmatch(r'(.*) \[(.*)\]', h).groups() for h in rows[0]]
data = np.array([[float(x) for x in r] for r in rows[1:]])
bits = lambda a: np.ascontiguousarray(a, dtype='<f8').view('<u8')
m = scipy.io.loadmat(folder + '/results.mat')
order = list(m['columns'].dtype.names)
text = lambda a: str(a[0]) if a.size else ''
mat_names = [text(m['columns'][0, 0][k]) for k in order]
mat_units = [text(m['units'][0, 0][k]) for k in order]
mat_equal = [bool(np.array_equal(bits(m[k].ravel()), bits(data[:, i]))) for i, k in enumerate(order)]
h = h5py.File(folder + '/results.h5', 'r')
h5_order = [str(x) for x in h.attrs['columns']]
h5_names = [str(h[k].attrs['name']) for k in h5_order]
h5_units = [str(h[k].attrs['unit']) for k in h5_order]
h5_equal = [bool(np.array_equal(bits(h[k][()]), bits(data[:, i]))) for i, k in enumerate(h5_order)]
meta = m['meta'][0, 0]
print(json.dumps({
    'rows': len(rows) - 1, 'csv_names': [n for n, u in header], 'csv_units': [u for n, u in header],
    'mat_variables': order, 'mat_names': mat_names, 'mat_units': mat_units, 'mat_equal': mat_equal,
    'h5_names': h5_names, 'h5_units': h5_units, 'h5_equal': h5_equal,
    'mat_status': text(meta['status']), 'mat_sha256': text(meta['model'][0, 0]['sha256']),
    'mat_version': text(meta['multibond_version']),
    'h5_root': {k: str(h.attrs[k]) for k in ('model', 'model_sha256', 'version', 'status', 'solver')}}))
)PY";

class FormatsCli : public ::testing::Test {
 protected:
  TempDir tmp_{"multibond-formats"};
  fs::path out_ = tmp_.path() / "out";
};

TEST_F(FormatsCli, CsvMatAndH5HoldTheSameNumbersAndRunJsonListsThem) {
  if (const std::string why = multibond::testing::PythonMissing({"numpy", "scipy.io", "h5py"}); !why.empty()) GTEST_SKIP() << why;
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "csv,mat,h5", "--jit", "off"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("wrote " + out_.string() + "/results.csv, " + out_.string() + "/results.mat, " + out_.string() +
                               "/results.h5 and " + out_.string() + "/run.json"));
  EXPECT_THAT(ListNames(out_), ElementsAre(".multibond.lock", "results.csv", "results.h5", "results.mat", "run.json"));

  const nlohmann::json run = nlohmann::json::parse(ReadFile(out_ / "run.json"));
  // "results" is results.csv's, as before; "files" lists every file, each as published.
  EXPECT_EQ(run["results"], run["files"][0].contains("format") ? nlohmann::json({{"file", "results.csv"}, {"bytes", run["files"][0]["bytes"]},
                                                                                 {"sha256", run["files"][0]["sha256"]}})
                                                               : nlohmann::json());
  ASSERT_EQ(run["files"].size(), 3u);
  const std::vector<std::string> files = {"results.csv", "results.mat", "results.h5"}, formats = {"csv", "mat", "h5"};
  for (size_t i = 0; i < 3; ++i) {
    const nlohmann::json& f = run["files"][i];
    EXPECT_EQ(f["file"], files[i]);
    EXPECT_EQ(f["format"], formats[i]);
    const std::string content = ReadFile(out_ / files[i]);
    EXPECT_EQ(f["bytes"], content.size());
    EXPECT_EQ(f["sha256"], multibond::Sha256Hex(content));
  }

  const CliResult py = multibond::testing::RunPython(kCompare, {out_.string()});
  ASSERT_EQ(py.code, 0) << py.out;
  const nlohmann::json j = nlohmann::json::parse(py.out);
  EXPECT_EQ(j["rows"], 5001);  // 0 to 5 s every 1 ms
  EXPECT_EQ(j["mat_names"], j["csv_names"]);
  EXPECT_EQ(j["mat_units"], j["csv_units"]);
  EXPECT_EQ(j["h5_names"], j["csv_names"]);
  EXPECT_EQ(j["h5_units"], j["csv_units"]);
  EXPECT_EQ(j["mat_equal"], std::vector<bool>(j["csv_names"].size(), true));
  EXPECT_EQ(j["h5_equal"], std::vector<bool>(j["csv_names"].size(), true));
  EXPECT_EQ(j["mat_variables"][0], "time");
  EXPECT_EQ(j["mat_variables"][1], "mass_p");
  EXPECT_EQ(j["mat_status"], "ok");
  EXPECT_EQ(j["mat_sha256"], run["model"]["sha256"]);
  EXPECT_EQ(j["mat_version"], run["multibond_version"]);
  EXPECT_EQ(j["h5_root"]["model"], run["model"]["file"]);
  EXPECT_EQ(j["h5_root"]["model_sha256"], run["model"]["sha256"]);
  EXPECT_EQ(j["h5_root"]["version"], run["multibond_version"]);
  EXPECT_EQ(j["h5_root"]["status"], "ok");
  EXPECT_EQ(j["h5_root"]["solver"], "bdf");
}

TEST_F(FormatsCli, OctaveLoadsTheSameColumnsAsTheCsv) {
  if (const std::string why = multibond::testing::OctaveMissing(); !why.empty()) GTEST_SKIP() << why;
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "csv,mat", "--jit", "off", "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  // dlmread reads the CSV's numbers (strtod: exact); isequal compares every value of each column.
  const CliResult o = multibond::testing::RunOctave(
      "d = dlmread('" + (out_ / "results.csv").string() + "', ',', 1, 0); load('" + (out_ / "results.mat").string() +
      "'); f = fieldnames(columns); same = 0;"
      "for k = 1:numel(f), same += isequal(d(:, k), eval(f{k})); end;"
      "printf('%d of %d columns equal, %d rows, unit %s, status %s\\n', same, numel(f), size(d, 1), units.mass_p, meta.status);");
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_THAT(o.out, HasSubstr("14 of 14 columns equal, 5001 rows, unit N s, status ok\n"));
}

TEST_F(FormatsCli, NamesThatCollideAfterSanitisingGetNumbersAndKeepTheirOriginals) {
  if (const std::string why = multibond::testing::PythonMissing({"scipy.io"}); !why.empty()) GTEST_SKIP() << why;
  // An output called mass_p (the MATLAB name of the state mass.p), one called meta (the file's
  // record) and one called end (a MATLAB keyword).
  fs::create_directories(tmp_.path());
  std::ofstream(tmp_.path() / "collide.yaml") << "model: collide\nelements:\n"
                                                 "  f: {type: Se, effort: 1.0}\n  j: {type: \"1\"}\n  mass: {type: I, inertia: 1.0}\n"
                                                 "bonds: [f -> j, j -> mass]\n"
                                                 "outputs:\n  - {name: mass_p, variable: j.f}\n  - {name: meta, variable: j.f}\n"
                                                 "  - {name: end, variable: j.f}\n";
  const CliResult r = RunCli({"run", (tmp_.path() / "collide.yaml").string(), "-o", out_.string(), "--format", "mat", "--t-end", "0.01",
                              "--jit", "off", "-q"});
  ASSERT_EQ(r.code, 0) << r.out;
  const CliResult py = multibond::testing::RunPython(
      "import sys, scipy.io; m = scipy.io.loadmat(sys.argv[1]); c = m['columns'][0, 0]\n"
      "print(' '.join(k + '=' + str(c[k][0]) for k in m['columns'].dtype.names if k.startswith(('mass', 'meta', 'end'))))",
      {(out_ / "results.mat").string()});
  ASSERT_EQ(py.code, 0) << py.out;
  EXPECT_EQ(py.out, "mass_p=mass.p mass_p_2=mass_p meta_2=meta end_2=end mass_energy=mass.energy\n");
}

TEST_F(FormatsCli, AnOutputNamedWithQuotesSemicolonsOrUnicodeIsRefusedBeforeAnythingIsWritten) {
  // Such a name never reaches a results file: the model's names are identifiers (docs/security.md).
  fs::create_directories(tmp_.path());
  std::ofstream(tmp_.path() / "hostile.yaml") << "model: hostile\nelements:\n  f: {type: Se, effort: 1.0}\n  j: {type: \"1\"}\n"
                                                 "  mass: {type: I, inertia: 1.0}\nbonds: [f -> j, j -> mass]\n"
                                                 "outputs:\n  - {name: \"v\\\";drop ω\", variable: j.f}\n";
  const CliResult r = RunCli({"run", (tmp_.path() / "hostile.yaml").string(), "-o", out_.string(), "--format", "csv,mat,h5"});
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("an output's name holds '\"'"));
  EXPECT_FALSE(fs::exists(out_));
}

TEST_F(FormatsCli, AnUnknownFormatIsAUsageErrorWithASuggestionAndWritesNothing) {
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "csv,hdf5"});
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_THAT(r.out, HasSubstr("unknown result format 'hdf5' in --format 'csv,hdf5' (did you mean 'h5'?); the formats are csv, mat, h5"));
  EXPECT_FALSE(fs::exists(out_));
  EXPECT_EQ(RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", ""}).code, 64);
  EXPECT_FALSE(fs::exists(out_));
}

TEST_F(FormatsCli, BinaryFormatsBeyondTheResultsSizeLimitAreRefusedBeforeTheRun) {
  // 5,001 rows x 14 columns x 8 bytes = 560 kB kept in memory.
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "h5", "--limit", "results-size=500k"});
  EXPECT_EQ(r.code, 64) << r.out;
  EXPECT_THAT(r.out, HasSubstr("--format h5 keeps the results in memory: 5001 rows x 14 columns x 8 bytes = 560 kB, more than the limit results-size; raise it with --limit results-size=N (now 500000)"));
  EXPECT_THAT(r.out, HasSubstr("--limit results-size="));
  EXPECT_FALSE(fs::exists(out_));
  // CSV streams its rows: no such limit.
  EXPECT_EQ(RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--limit", "results-size=500k", "-q"}).code, 0);
}

TEST_F(FormatsCli, OnlyTheFormatsAskedForAreWrittenAndAnEarlierRunsOthersAreRemoved) {
  ASSERT_EQ(RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "csv,mat,h5", "-q"}).code, 0);
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "h5", "--t-end", "1"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("wrote " + out_.string() + "/results.h5 and " + out_.string() + "/run.json"));
  // The earlier run's results.csv and results.mat would describe another run: gone.
  EXPECT_THAT(ListNames(out_), ElementsAre(".multibond.lock", "results.h5", "run.json"));
  const nlohmann::json run = nlohmann::json::parse(ReadFile(out_ / "run.json"));
  EXPECT_FALSE(run.contains("results"));
  ASSERT_EQ(run["files"].size(), 1u);
  EXPECT_EQ(run["files"][0]["file"], "results.h5");
  EXPECT_EQ(run["files"][0]["compressed"], false);
}

TEST_F(FormatsCli, ADivergingRunKeepsItsRowsInEveryFormat) {
  if (const std::string why = multibond::testing::PythonMissing({"scipy.io", "h5py"}); !why.empty()) GTEST_SKIP() << why;
  // RK4 far beyond its stability limit: the run fails; what it computed is kept, marked failed.
  const CliResult r = RunCli({"run", Example("mass_spring_damper.yaml"), "-o", out_.string(), "--format", "csv,mat,h5", "--compress",
                              "--solver", "rk4", "--step", "0.5", "--dt", "0.5", "--t-end", "500"});
  ASSERT_EQ(r.code, 2) << r.out;
  const nlohmann::json run = nlohmann::json::parse(ReadFile(out_ / "run.json"));
  EXPECT_EQ(run["status"], "failed");
  const long samples = run["samples"].get<long>();
  EXPECT_GT(samples, 0);
  EXPECT_LT(samples, 1001);
  const CliResult py = multibond::testing::RunPython(
      "import sys, scipy.io, h5py; d = sys.argv[1]; m = scipy.io.loadmat(d + '/results.mat'); h = h5py.File(d + '/results.h5', 'r')\n"
      "print(m['time'].size, h['time'].shape[0], m['meta'][0, 0]['status'][0], h.attrs['status'], h['time'].compression, "
      "sum(1 for _ in open(d + '/results.csv')) - 1)",
      {out_.string()});
  ASSERT_EQ(py.code, 0) << py.out;
  EXPECT_EQ(py.out, std::to_string(samples) + " " + std::to_string(samples) + " failed failed gzip " + std::to_string(samples) + "\n");
}

}  // namespace
