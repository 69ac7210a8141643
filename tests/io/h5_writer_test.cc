// results.h5 as h5py sees it: one dataset per column named by the column (a '/' escaped), every
// value to the last bit, `unit`, `name` and `column` attributes, the run record on the root group,
// chunked, and compressed (shuffle, deflate) when asked.
#include "multibond/io/h5_writer.h"

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
#include "multibond/version.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using testing::BitsOf;
using testing::TempDir;

ColumnStore Store() {
  ColumnStore s(3);
  s.OnStart({{"time", "s"}, {"A.omega.z", "rad/s"}, {"a/b", "N s"}, {"100%", "-"}, {"x\"; drop ω", "m"}, {".", "J"}});
  const double inf = std::numeric_limits<double>::infinity();
  s.OnSample({0.0, 1.0 / 3.0, -0.0, std::nan(""), inf, std::numeric_limits<double>::denorm_min()});
  s.OnSample({0.1, 1e308, M_PI, -inf, 2.0, 3.0});
  s.OnSample({0.2, 7.0, 8.0, 9.0, 10.0, 11.0});
  return s;
}

const nlohmann::json kRecord = {{"model", {{"file", "m\"o;d.yaml"}, {"name", "msd"}, {"sha256", std::string(64, 'b')}}},
                                {"options", {{"solver", "dopri5"}, {"rtol", 1e-6}, {"atol", 1e-9}, {"t_start", 0.0}, {"t_end", 0.2}, {"dt", 0.1}}},
                                {"status", "interrupted"},
                                {"message", "interrupted by SIGINT"},
                                {"t_reached", 0.2}};

TEST(H5DatasetNames, TheColumnsNamesWithSlashAndPercentEscaped) {
  EXPECT_THAT(H5DatasetNames(Store().columns()), ElementsAre("time", "A.omega.z", "a%2Fb", "100%25", "x\"; drop ω", "%2E"));
}

constexpr const char* kH5pyReader = R"PY(
import json, sys
import h5py
f = h5py.File(sys.argv[1], 'r')
def s(x):
    return x.decode() if isinstance(x, bytes) else str(x)
out = {'datasets': sorted(f.keys()), 'root': {}, 'sets': {}}
for k, v in f.attrs.items():
    out['root'][k] = [s(e) for e in v] if k == 'columns' else (s(v) if isinstance(v, (str, bytes)) else v.item())
for name in f:
    d = f[name]
    out['sets'][name] = {
        'bits': ['%016x' % x for x in d[()].astype('<f8').view('<u8')],
        'dtype': d.dtype.str, 'shape': list(d.shape), 'chunks': list(d.chunks or []),
        'compression': d.compression or '', 'shuffle': bool(d.shuffle),
        'unit': s(d.attrs['unit']), 'name': s(d.attrs['name']), 'column': int(d.attrs['column'])}
print(json.dumps(out))
)PY";

TEST(H5Writer, H5pyReadsEveryValueToTheLastBitWithUnitsAndTheRunRecord) {
  if (const std::string why = testing::PythonMissing({"h5py"}); !why.empty()) GTEST_SKIP() << why;
  for (const bool compress : {false, true}) {
    SCOPED_TRACE(compress ? "compressed" : "uncompressed");
    TempDir dir;
    const std::string path = (dir.path() / "results.h5").string();
    const ColumnStore s = Store();
    WriteH5Results(path, s, kRecord, compress);
    const testing::CliResult r = testing::RunPython(kH5pyReader, {path});
    ASSERT_EQ(r.code, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    const std::vector<std::string> names = H5DatasetNames(s.columns());
    std::vector<std::string> sorted = names;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(j["datasets"], sorted);
    for (size_t c = 0; c < names.size(); ++c) {
      SCOPED_TRACE(names[c]);
      const nlohmann::json& d = j["sets"][names[c]];
      EXPECT_THAT(d["bits"].get<std::vector<std::string>>(), ElementsAreArray(BitsOf(s.values(c))));
      EXPECT_EQ(d["dtype"], "<f8");
      EXPECT_EQ(d["shape"], std::vector<int>{3});
      EXPECT_EQ(d["chunks"], std::vector<int>{3});
      EXPECT_EQ(d["compression"], compress ? "gzip" : "");
      EXPECT_EQ(d["shuffle"], compress);
      EXPECT_EQ(d["unit"], s.columns()[c].unit);
      EXPECT_EQ(d["name"], s.columns()[c].name);
      EXPECT_EQ(d["column"], c);
    }
    const nlohmann::json& root = j["root"];
    EXPECT_EQ(root["model"], "m\"o;d.yaml");
    EXPECT_EQ(root["model_name"], "msd");
    EXPECT_EQ(root["model_sha256"], std::string(64, 'b'));
    EXPECT_EQ(root["version"], kVersion);
    EXPECT_EQ(root["status"], "interrupted");
    EXPECT_EQ(root["message"], "interrupted by SIGINT");
    EXPECT_EQ(root["solver"], "dopri5");
    EXPECT_EQ(root["rtol"], 1e-6);
    EXPECT_EQ(root["atol"], 1e-9);
    EXPECT_EQ(root["dt"], 0.1);
    EXPECT_EQ(root["t_end"], 0.2);
    EXPECT_EQ(root["t_reached"], 0.2);
    EXPECT_EQ(root["samples"], 3);
    EXPECT_EQ(root["columns"], names);  // the order of results.csv
    EXPECT_EQ(nlohmann::json::parse(root["run_record"].get<std::string>()), kRecord);
  }
}

TEST(H5Writer, ARunThatStoppedBeforeItsFirstRowGivesEmptyDatasets) {
  if (const std::string why = testing::PythonMissing({"h5py"}); !why.empty()) GTEST_SKIP() << why;
  TempDir dir;
  const std::string path = (dir.path() / "results.h5").string();
  ColumnStore s;
  s.OnStart({{"time", "s"}, {"mass.p", "N s"}});
  WriteH5Results(path, s, {{"status", "failed"}}, true);
  const testing::CliResult r = testing::RunPython(
      "import sys, h5py; f = h5py.File(sys.argv[1], 'r'); print(f['time'].shape, f['mass.p'].shape, f.attrs['status'])", {path});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "(0,) (0,) failed\n");
}

TEST(H5Writer, AFileThatCannotBeCreatedIsSaidWithItsPathAndNothingOnStderr) {
  ColumnStore s;
  s.OnStart({{"time", "s"}});
  ::testing::internal::CaptureStderr();
  EXPECT_THAT([&] { WriteH5Results("/nonexistent-folder/results.h5", s, {}, false); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("cannot write '/nonexistent-folder/results.h5'")));
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");  // HDF5's own error stack is not printed
}

}  // namespace
}  // namespace multibond
