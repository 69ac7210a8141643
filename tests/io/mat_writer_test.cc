// results.mat as MATLAB's readers see it: written from a ColumnStore, read with SciPy
// (scipy.io.loadmat, Debian's python3) and Octave (load). Every value comes back to the last bit
// (NaN, infinities, -0, the smallest subnormal among them); names from a model file, however
// hostile, give valid MATLAB names and survive in `columns`; units and the run record are there.
#include "multibond/io/mat_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/external_readers.h"
#include "multibond/io/result_names.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using testing::Bits;
using testing::BitsOf;
using testing::TempDir;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Columns with names a model file could not hold but a writer must survive, and values that
/// test every bit.
ColumnStore HostileStore() {
  ColumnStore s(4);
  s.OnStart({{"time", "s"},
             {"A.omega.z", "rad/s"},
             {"A_omega_z", "rad/s"},
             {"x\"; system('rm -rf ~'); %", "N s"},
             {"ünï.ω/ü", "m"},
             {"meta", "-"},
             {"end", "J"},
             {std::string(70, 'q'), "m"}});
  const double tiny = std::numeric_limits<double>::denorm_min();
  s.OnSample({0.0, 1.0 / 3.0, -0.0, M_PI, std::nan(""), kInf, -kInf, tiny});
  s.OnSample({0.1, 1e308, 0.1, -1e-300, 2.0, 3.0, 4.0, 5.0});
  s.OnSample({0.2, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0});
  return s;
}

const nlohmann::json kRecord = {{"multibond_version", "0.1.0"},
                                {"model", {{"file", "m\"o;d.yaml"}, {"name", "msd"}, {"sha256", std::string(64, 'a')}}},
                                {"options", {{"solver", "bdf"}, {"rtol", 1e-8}, {"projection", true}}},
                                {"status", "failed"},
                                {"message", "at t = 0.2 s: ω"},
                                {"command_line", {"multibond", "run", "m.yaml"}},
                                {"warnings", nlohmann::json::array()},
                                {"parameters", {{"k", {{"value", 100.0}, {"unit", "N/m"}}}}},
                                {"samples", 3},
                                {"nothing", nullptr}};

TEST(MatVariableNames, TimeFirstAndTheFilesOwnNamesKeptFree) {
  const std::vector<std::string> names = MatVariableNames(HostileStore().columns());
  EXPECT_THAT(names, ElementsAre("time", "A_omega_z", "A_omega_z_2", "x___system__rm__rf_______", "x_n_____", "meta_2", "end_2",
                                 std::string(63, 'q')));
  for (const std::string& n : names) EXPECT_TRUE(IsMatlabName(n)) << n;
}

constexpr const char* kScipyReader = R"PY(
import json, sys
import numpy as np
import scipy.io
# MATLAB's characters are UTF-16 code units; SciPy reads them as such when told.
m = scipy.io.loadmat(sys.argv[1], uint16_codec='utf-16-le')
def text(a):
    return str(a[0]) if a.size else ''
order = list(m['columns'].dtype.names)
columns, units = m['columns'][0, 0], m['units'][0, 0]
meta = m['meta'][0, 0]
out = {
    'variables': sorted(k for k in m if not k.startswith('__')),
    'order': order,
    'columns': {k: text(columns[k]) for k in order},
    'units': {k: text(units[k]) for k in order},
    'shapes': {k: list(m[k].shape) for k in order},
    'bits': {k: ['%016x' % x for x in m[k].astype('<f8').view('<u8').ravel()] for k in order},
    'status': text(meta['status']),
    'message': text(meta['message']),
    'model_file': text(meta['model'][0, 0]['file']),
    'model_sha256': text(meta['model'][0, 0]['sha256']),
    'rtol': float(meta['options'][0, 0]['rtol'][0, 0]),
    'projection': bool(meta['options'][0, 0]['projection'][0, 0]),
    'command_line': [text(c) for c in meta['command_line'][0]],
    'k': float(meta['parameters'][0, 0]['k'][0, 0]['value'][0, 0]),
    'samples': float(meta['samples'][0, 0]),
}
print(json.dumps(out))
)PY";

TEST(MatWriter, ScipyReadsEveryValueToTheLastBitWithNamesUnitsAndRecord) {
  if (const std::string why = testing::PythonMissing({"numpy", "scipy.io"}); !why.empty()) GTEST_SKIP() << why;
  for (const bool compress : {false, true}) {
    SCOPED_TRACE(compress ? "compressed" : "uncompressed");
    TempDir dir;
    const std::string path = (dir.path() / "results.mat").string();
    const ColumnStore s = HostileStore();
    WriteMatResults(path, s, kRecord, compress);
    const testing::CliResult r = testing::RunPython(kScipyReader, {path});
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    const std::vector<std::string> names = MatVariableNames(s.columns());
    std::vector<std::string> variables = names;
    for (const char* own : {"units", "columns", "meta"}) variables.push_back(own);
    std::sort(variables.begin(), variables.end());
    EXPECT_EQ(j["variables"], variables);
    EXPECT_EQ(j["order"], names);
    for (size_t c = 0; c < names.size(); ++c) {
      EXPECT_EQ(j["columns"][names[c]], s.columns()[c].name);  // the hostile and unicode ones too
      EXPECT_EQ(j["units"][names[c]], s.columns()[c].unit);
      EXPECT_EQ(j["shapes"][names[c]], (std::vector<int>{3, 1}));  // a column vector
      EXPECT_THAT(j["bits"][names[c]].get<std::vector<std::string>>(), ElementsAreArray(BitsOf(s.values(c)))) << names[c];
    }
    EXPECT_EQ(j["status"], "failed");
    EXPECT_EQ(j["message"], "at t = 0.2 s: ω");
    EXPECT_EQ(j["model_file"], "m\"o;d.yaml");
    EXPECT_EQ(j["model_sha256"], std::string(64, 'a'));
    EXPECT_EQ(j["rtol"], 1e-8);
    EXPECT_EQ(j["projection"], true);
    EXPECT_EQ(j["command_line"], (std::vector<std::string>{"multibond", "run", "m.yaml"}));
    EXPECT_EQ(j["k"], 100.0);
    EXPECT_EQ(j["samples"], 3.0);
  }
}

TEST(MatWriter, OctaveLoadsTheColumnsUnitsAndRecord) {
  if (const std::string why = testing::OctaveMissing(); !why.empty()) GTEST_SKIP() << why;
  TempDir dir;
  const std::string path = (dir.path() / "results.mat").string();
  ColumnStore s(2);
  s.OnStart({{"time", "s"}, {"A.omega.z", "rad/s"}, {"a;b\"c", "N s"}, {"meta", "-"}, {"ünï.ω", "Ω"}});
  s.OnSample({0.0, 1.0 / 3.0, -0.0, std::nan(""), 1e-300});
  s.OnSample({0.1, 1e308, M_PI, -kInf, 2.5});
  WriteMatResults(path, s, kRecord, /*compress=*/true);
  // One line per column: its variable, original name, unit and values' bits.
  const testing::CliResult r = testing::RunOctave(
      "load('" + path + "'); f = fieldnames(columns);"
      "for k = 1:numel(f), v = eval(f{k}); h = cellstr(num2hex(v))';"
      "  printf('%s|%s|%s|%s|%dx%d\\n', f{k}, columns.(f{k}), units.(f{k}), strjoin(h, ','), size(v, 1), size(v, 2)); end;"
      "printf('meta|%s|%s|%s|%g|%s|%s\\n', meta.status, meta.model.file, meta.model.sha256, meta.options.rtol,"
      "       class(meta.options.projection), meta.message);");
  ASSERT_EQ(r.code, 0) << r.out;
  std::vector<std::string> expected;
  const std::vector<std::string> names = MatVariableNames(s.columns());
  for (size_t c = 0; c < names.size(); ++c)
    expected.push_back(fmt::format("{}|{}|{}|{},{}|2x1", names[c], s.columns()[c].name, s.columns()[c].unit, Bits(s.values(c)[0]),
                                   Bits(s.values(c)[1])));
  expected.push_back(fmt::format("meta|failed|m\"o;d.yaml|{}|1e-08|logical|at t = 0.2 s: ω", std::string(64, 'a')));
  for (const std::string& line : expected) EXPECT_THAT(r.out, ::testing::HasSubstr(line + "\n"));
}

TEST(MatWriter, ARunThatStoppedBeforeItsFirstRowGivesEmptyColumns) {
  if (const std::string why = testing::PythonMissing({"scipy.io"}); !why.empty()) GTEST_SKIP() << why;
  TempDir dir;
  const std::string path = (dir.path() / "results.mat").string();
  ColumnStore s;
  s.OnStart({{"time", "s"}, {"mass.p", "N s"}});
  WriteMatResults(path, s, {{"status", "interrupted"}}, false);
  const testing::CliResult r = testing::RunPython(
      "import sys, scipy.io; m = scipy.io.loadmat(sys.argv[1]); print(m['time'].size, m['mass_p'].size, m['meta'][0, 0]['status'][0])",
      {path});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "0 0 interrupted\n");
}

TEST(MatWriter, AFileThatCannotBeCreatedIsSaidWithItsPath) {
  ColumnStore s;
  s.OnStart({{"time", "s"}});
  EXPECT_THAT([&] { WriteMatResults("/nonexistent-folder/results.mat", s, {}, false); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("cannot write '/nonexistent-folder/results.mat'")));
}

}  // namespace
}  // namespace multibond
