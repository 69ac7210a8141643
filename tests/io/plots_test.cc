// MakeFigures and WriteResultsPage. The paper's figures, drawn from the figure list
// examples/differential/figures.yaml on a small synthetic results folder (a run of the
// differential takes too long for this suite): every figure is written as PNG and SVG under its
// contract name, each panel plots the columns it should (its data extent, as gnuplot saw it,
// against the CSV), and the page shows every figure and renders in a headless Chromium. The
// general figures, through the CLI, of the mass-spring-damper and the DC motor; bounded on a
// results.csv of 10,000 columns.
#include "support/errors.h"
#include "support/cli_runner.h"
#include "support/temp_dir.h"
#include "multibond/io/plot_auto.h"
#include "multibond/io/plot_web.h"
#include "multibond/io/plots.h"
#include "multibond/io/results_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace multibond {
namespace {

using testing::RuntimeErrorOf;

namespace fs = std::filesystem;
using ::testing::HasSubstr;

/// The names the issue fixes (figure number, link, quantity).
const std::vector<std::string> kContractNames = {
    "fig03-G-orientation", "fig04-G-com",        "fig05-G-momentum",     "fig06-G-torque",       "fig07-G-reaction",
    "fig08-A-orientation", "fig09-A-com",        "fig10-A-momentum",     "fig11-A-reaction",     "fig12-S1-orientation",
    "fig13-S1-com",        "fig14-S1-momentum",  "fig15-S1-reaction",    "fig16-S2-orientation", "fig17-S2-com",
    "fig18-S2-momentum",   "fig19-S2-reaction",  "fig20-P1-orientation", "fig21-P1-com",         "fig22-P1-momentum",
    "fig23-P1-reaction",   "fig24-P2-orientation", "fig25-P2-com",       "fig26-P2-momentum",    "fig27-P2-reaction",
    "fig28-P1-rim-point",  "fig29-P2-rim-point", "fig30-H-orientation",  "fig31-H-com",          "fig32-H-momentum",
    "fig33-H-reaction"};

/// Shared helpers (tests/support/temp_dir.h); the folder keeps this file's prefix.
struct TempDir : multibond::testing::TempDir {
  TempDir() : multibond::testing::TempDir("multibond-plots-test") {}
};
using multibond::testing::ReadFile;

/// A synthetic run: the columns the figures and the page use, with values that tell the columns
/// apart (each column's range is its own), kept in memory for the checks.
class SyntheticRun {
 public:
  static constexpr int kRows = 401;  // 0 to 2 s every 5 ms
  static constexpr double kDt = 0.005;

  SyntheticRun() {
    Add("time", "s", [](double t) { return t; });
    const std::vector<std::string> bodies = {"H", "G", "A", "P1", "P2", "S1", "S2"};
    const std::map<std::string, std::array<double, 2>> rates = {  // about z, then about x [rad/s]
        {"H", {0, 0}}, {"G", {0, 5}}, {"A", {-1.25, 0}}, {"P1", {-1.25, 2.5}}, {"P2", {-1.25, 2.5}}, {"S1", {0, 0}}, {"S2", {-2.5, 0}}};
    for (const std::string& b : bodies) {
      const auto [wz, wx] = rates.at(b);
      // R = Rz(wz t) Rx(wx t), row-major.
      for (int i = 1; i <= 3; ++i)
        for (int j = 1; j <= 3; ++j)
          Add(fmt::format("{}.R.{}{}", b, i, j), "-", [=](double t) { return Rotation(wz * t, wx * t)[3 * (i - 1) + (j - 1)]; });
      const bool planet = b == "P1" || b == "P2";
      const double phase = b == "P2" ? M_PI : 0.0;
      Add(b + ".r.x", "m", [=](double t) { return planet ? 0.5 + 0.1 * std::cos(-1.25 * t + phase) : 0.3 + 1e-6 * std::sin(40 * t); });
      Add(b + ".r.y", "m", [=](double t) { return planet ? 0.5 + 0.1 * std::sin(-1.25 * t + phase) : 0.5 - 2e-6 * std::sin(30 * t); });
      Add(b + ".r.z", "m", [=](double t) { return planet ? 0.5 : 0.45 + 3e-6 * std::sin(20 * t); });
      for (const char* q : {"p", "h", "F", "M", "v", "omega"})
        for (const char* a : {"x", "y", "z"}) AddDistinct(fmt::format("{}.{}.{}", b, q, a), Unit(q));
    }
    Add("drive.torque", "N m", [](double t) { return 250 * std::exp(-t / 0.05) * std::cos(100 * t); });
    for (const char* q : {"Q_P1", "Q_P2"})
      for (const char* a : {"x", "y", "z"}) AddDistinct(fmt::format("{}.{}", q, a), "m");
    for (const char* e : {"energy.work", "energy.kinetic", "energy.potential", "energy.dissipated"}) AddDistinct(e, "J");
    Add("energy.residual", "-", [](double t) { return 1e-9 * std::sin(t); });
  }

  /// Writes results.csv and run.json into `dir`; `skip` leaves a column out. Header cells are
  /// CSV-quoted when they need it, as CsvWriter writes them.
  void Write(const fs::path& dir, const std::string& skip = "") const {
    std::ofstream csv(dir / "results.csv");
    std::string header;
    for (size_t c = 0; c < names_.size(); ++c)
      if (names_[c] != skip) {
        if (!header.empty()) header += ',';
        header += CsvCell(fmt::format("{} [{}]", names_[c], units_[c]));
      }
    csv << header << "\n";
    for (int r = 0; r < kRows; ++r) {
      std::string line;
      for (size_t c = 0; c < names_.size(); ++c)
        if (names_[c] != skip) {
          if (!line.empty()) line += ',';
          line += fmt::format("{:.17g}", cols_[c][r]);
        }
      csv << line << "\n";
    }
    std::ofstream(dir / "run.json") << R"({"model": {"name": "synthetic", "file": "none.yaml", "sha256": "00"},
      "status": "ok", "samples": 401, "options": {"solver": "bdf", "rtol": 1e-8, "atol": 1e-10, "dt": 0.005},
      "energy": {"work": 1.0, "stored": 0.5, "dissipated": 0.5, "residual": 1e-9, "max_abs_residual": 2e-9},
      "solver_stats": {"steps": 10, "rhs_evals": 20, "jac_evals": 1}, "wall_seconds": 0.1, "multibond_version": "test"})";
  }

  /// Gives column `name` another unit (text of a hand-crafted results.csv).
  void SetUnit(const std::string& name, const std::string& unit) {
    for (size_t c = 0; c < names_.size(); ++c)
      if (names_[c] == name) units_[c] = unit;
  }

  /// Sets column `name` to `v` from row `from` on.
  void SetValues(const std::string& name, double v, int from = 0) {
    for (size_t c = 0; c < names_.size(); ++c)
      if (names_[c] == name)
        for (int r = from; r < kRows; ++r) cols_[c][r] = v;
  }

  const std::vector<double>& Col(const std::string& name) const {
    for (size_t c = 0; c < names_.size(); ++c)
      if (names_[c] == name) return cols_[c];
    ADD_FAILURE() << "no column " << name;
    static const std::vector<double> empty;
    return empty;
  }

  /// min/max of `f(column value, first value)` over rows kept by `keep(row, time)`, union over the columns.
  std::pair<double, double> Range(const std::vector<std::string>& columns, const std::function<bool(int, double)>& keep,
                                  const std::function<double(double, double)>& f = [](double v, double) { return v; }) const {
    double lo = INFINITY, hi = -INFINITY;
    const auto& time = Col("time");
    for (const std::string& c : columns) {
      const auto& v = Col(c);
      for (int r = 0; r < kRows; ++r)
        if (keep(r, time[r])) {
          lo = std::min(lo, f(v[r], v[0]));
          hi = std::max(hi, f(v[r], v[0]));
        }
    }
    return {lo, hi};
  }

 private:
  static std::array<double, 9> Rotation(double z, double x) {
    const double cz = std::cos(z), sz = std::sin(z), cx = std::cos(x), sx = std::sin(x);
    // Rz * Rx
    return {cz, -sz * cx, sz * sx, sz, cz * cx, -cz * sx, 0, sx, cx};
  }
  static std::string Unit(const std::string& q) {
    if (q == "p") return "N s";
    if (q == "h") return "N m s";
    if (q == "F") return "N";
    if (q == "M") return "N m";
    if (q == "v") return "m/s";
    return "rad/s";
  }
  void Add(const std::string& name, const std::string& unit, const std::function<double(double)>& f) {
    names_.push_back(name);
    units_.push_back(unit);
    std::vector<double> v(kRows);
    for (int r = 0; r < kRows; ++r) v[r] = f(r * kDt);
    cols_.push_back(std::move(v));
  }
  /// A column whose values lie in a band of their own: [0.1 k - 0.05, 0.1 k + 0.05] for the k-th such column.
  void AddDistinct(const std::string& name, const std::string& unit) {
    const double k = ++distinct_;
    Add(name, unit, [k](double t) { return 0.1 * k + 0.05 * std::sin((1 + 0.07 * k) * t + k) * std::exp(-0.3 * t); });
  }

  std::vector<std::string> names_, units_;
  std::vector<std::vector<double>> cols_;
  int distinct_ = 0;
};

/// plots/<name>.ranges: panel id -> {xmin, xmax, ymin, ymax[, zmin, zmax]}.
std::map<std::string, std::vector<double>> ReadRanges(const fs::path& dir, const std::string& name) {
  std::map<std::string, std::vector<double>> out;
  std::istringstream in(ReadFile(dir / "plots" / (name + ".ranges")));
  for (std::string line; std::getline(in, line);) {
    std::istringstream f(line);
    std::string id;
    f >> id;
    std::vector<double> v;
    for (double x; f >> x;) v.push_back(x);
    out[id] = v;
  }
  return out;
}

void ExpectRange(const std::vector<double>& got, size_t at, std::pair<double, double> want, const std::string& what) {
  ASSERT_GE(got.size(), at + 2) << what;
  const double tol = 1e-9 * std::max({1.0, std::abs(want.first), std::abs(want.second)});
  EXPECT_NEAR(got[at], want.first, tol) << what << " (min)";
  EXPECT_NEAR(got[at + 1], want.second, tol) << what << " (max)";
}

std::vector<std::string> Xyz(const std::string& prefix) { return {prefix + ".x", prefix + ".y", prefix + ".z"}; }

bool Exists(const fs::path& p) {
  std::error_code ec;
  return fs::exists(p, ec) && fs::file_size(p, ec) > 0;
}

/// The paper's figure list.
const std::string kPaperFigures = std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential/figures.yaml";

/// The names of the paper's figures, as the figure list gives them.
std::vector<std::string> PaperFigureNames() { return FigureNames(ReadFigureList(kPaperFigures)); }

PlotOptions Options() {
  PlotOptions o;
  o.figures_path = kPaperFigures;
  o.model_path = std::string(MULTIBOND_SOURCE_DIR) + "/examples/differential.yaml";
  return o;
}

PlotOptions NoBondGraph() {
  PlotOptions o;
  o.figures_path = kPaperFigures;
  o.bond_graph = false;
  return o;
}

TEST(PlotsTest, NamesAreTheContract) {
  std::vector<std::string> want = {"fig02-bond-graph"};
  want.insert(want.end(), kContractNames.begin(), kContractNames.end());
  EXPECT_EQ(PaperFigureNames(), want);
}

TEST(PlotsTest, EveryFigureFromTheRightColumns) {
  TempDir dir;
  const SyntheticRun run;
  run.Write(dir.path());
  const PlotReport report = MakeFigures(dir.path().string(), Options());
  for (const std::string& w : report.warnings) ADD_FAILURE() << "warning: " << w;

  // Every figure, PNG and SVG, non-empty, and reported.
  std::set<std::string> reported(report.files.begin(), report.files.end());
  for (const std::string& name : PaperFigureNames())
    for (const char* ext : {".png", ".svg"}) {
      const fs::path p = dir.path() / "figures" / (name + ext);
      EXPECT_TRUE(Exists(p)) << p;
      EXPECT_TRUE(reported.count(p.string())) << p;
      EXPECT_LT(fs::file_size(p), 2u << 20) << p;
    }
  EXPECT_EQ(report.files.size(), 2 * PaperFigureNames().size());
  EXPECT_EQ(ReadFile(dir.path() / "figures" / "fig05-G-momentum.png").substr(1, 3), "PNG");
  EXPECT_NE(ReadFile(dir.path() / "figures" / "fig05-G-momentum.svg").find("<svg"), std::string::npos);
  // The scripts are kept, hold the columns they draw and say which columns those are.
  const std::string gp = ReadFile(dir.path() / "plots" / "fig05-G-momentum.gp");
  EXPECT_NE(gp.find("$d << EOD\n"), std::string::npos) << gp;
  EXPECT_EQ(gp.find("\"results.csv\""), std::string::npos) << gp;
  EXPECT_NE(gp.find("G.h.x [N m s]"), std::string::npos) << gp;
  EXPECT_NE(gp.find("Fig. 5. Variation of components of momentum of link G with time"), std::string::npos) << gp;
  EXPECT_NE(ReadFile(dir.path() / "plots" / "fig02-bond-graph.dot").find("cluster_G_bearing"), std::string::npos);

  // What gnuplot plotted, panel by panel, against the CSV.
  const double t1 = (SyntheticRun::kRows - 1) * SyntheticRun::kDt, zoom = 0.5;
  auto all = [](int, double) { return true; };
  auto early = [&](int, double t) { return t <= zoom + 1e-12; };
  const int last = SyntheticRun::kRows - 1;
  auto path_rows = [&](int r, double) { return r % 5 == 0 || r == last; };  // every 5th row, and the end point

  auto r = ReadRanges(dir.path(), "fig05-G-momentum");
  ExpectRange(r["a"], 0, {0.0, t1}, "fig05 a: time axis covers the run");
  ExpectRange(r["a"], 2, run.Range(Xyz("G.h"), all), "fig05 a: G.h");
  ExpectRange(r["a-zoom"], 0, {0.0, zoom}, "fig05 a-zoom: time axis");
  ExpectRange(r["a-zoom"], 2, run.Range(Xyz("G.h"), early), "fig05 a-zoom: G.h over the start");

  r = ReadRanges(dir.path(), "fig06-G-torque");
  ExpectRange(r["a"], 2, run.Range({"drive.torque"}, all), "fig06: drive.torque");
  ExpectRange(r["a-zoom"], 2, run.Range({"drive.torque"}, early), "fig06 zoom: drive.torque");

  r = ReadRanges(dir.path(), "fig22-P1-momentum");
  ExpectRange(r["a"], 2, run.Range(Xyz("P1.p"), all), "fig22 a: P1.p");
  ExpectRange(r["b"], 2, run.Range(Xyz("P1.h"), all), "fig22 b: P1.h");
  ExpectRange(r["b-zoom"], 2, run.Range(Xyz("P1.h"), early), "fig22 b-zoom: P1.h");

  r = ReadRanges(dir.path(), "fig27-P2-reaction");
  ExpectRange(r["a"], 2, run.Range(Xyz("P2.F"), all), "fig27 a: P2.F");
  ExpectRange(r["b"], 2, run.Range(Xyz("P2.M"), all), "fig27 b: P2.M");

  r = ReadRanges(dir.path(), "fig07-G-reaction");
  ExpectRange(r["a"], 2, run.Range(Xyz("G.F"), all), "fig07: G.F");
  EXPECT_EQ(r.count("b"), 0u) << "the paper's Fig. 7 has no moment panel";

  r = ReadRanges(dir.path(), "fig31-H-com");
  ExpectRange(r["a"], 2, run.Range(Xyz("H.r"), all), "fig31 a: H.r");
  ExpectRange(r["b"], 2, run.Range(Xyz("H.r"), all, [](double v, double v0) { return (v - v0) * 1e6; }), "fig31 b: H.r - r(0) in um");

  r = ReadRanges(dir.path(), "fig21-P1-com");
  ExpectRange(r["a"], 2, run.Range(Xyz("P1.r"), all), "fig21 a: P1.r");
  ExpectRange(r["b"], 0, run.Range({"P1.r.x"}, path_rows), "fig21 b: path x");
  ExpectRange(r["b"], 2, run.Range({"P1.r.y"}, path_rows), "fig21 b: path y");
  ExpectRange(r["b"], 4, run.Range({"P1.r.z"}, path_rows), "fig21 b: path z");

  r = ReadRanges(dir.path(), "fig29-P2-rim-point");
  ExpectRange(r["a"], 2, run.Range(Xyz("Q_P2"), all), "fig29 a: Q_P2");
  ExpectRange(r["b"], 4, run.Range({"Q_P2.z"}, path_rows), "fig29 b: path z");

  // Orientation: the tips of the columns of R: x of every tip is row 1 of R, and so on.
  r = ReadRanges(dir.path(), "fig20-P1-orientation");
  ExpectRange(r["a"], 0, run.Range({"P1.R.11", "P1.R.12", "P1.R.13"}, path_rows), "fig20: x of the tips = row 1 of R");
  ExpectRange(r["a"], 2, run.Range({"P1.R.21", "P1.R.22", "P1.R.23"}, path_rows), "fig20: y of the tips = row 2 of R");
  ExpectRange(r["a"], 4, run.Range({"P1.R.31", "P1.R.32", "P1.R.33"}, path_rows), "fig20: z of the tips = row 3 of R");

  // Every figure's panels all report, with the run's time axis.
  for (const std::string& name : kContractNames) {
    const auto ranges = ReadRanges(dir.path(), name);
    EXPECT_FALSE(ranges.empty()) << name;
    for (const auto& [id, v] : ranges)
      if (v.size() == 4 && id.find("zoom") == std::string::npos) ExpectRange(v, 0, {0.0, t1}, name + " " + id + ": time axis");
  }
}

// Progress (#43: plot ran for seconds with nothing on the terminal): one call as each figure's
// gnuplot run ends, counting up to the figures drawn (the paper's 31 time and 3D figures; the bond
// graph is Graphviz's, left out here).
TEST(PlotsTest, ProgressCountsTheFiguresAsTheyEnd) {
  TempDir dir;
  const SyntheticRun run;
  run.Write(dir.path());
  PlotOptions o = NoBondGraph();
  std::vector<std::pair<size_t, size_t>> calls;
  o.progress = [&](size_t done, size_t total) { calls.emplace_back(done, total); };
  MakeFigures(dir.path().string(), o);
  const size_t figures = PaperFigureNames().size() - 1;
  ASSERT_EQ(calls.size(), figures);
  for (size_t k = 0; k < calls.size(); ++k) {
    EXPECT_EQ(calls[k].first, k + 1);
    EXPECT_EQ(calls[k].second, figures);
  }
}

TEST(PlotsTest, MissingColumnsLeaveTheFigureOutWithAWarning) {
  TempDir dir;
  SyntheticRun().Write(dir.path(), "S2.F.y");
  PlotOptions o;
  o.figures_path = kPaperFigures;
  o.bond_graph = false;
  const PlotReport report = MakeFigures(dir.path().string(), o);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("Fig. 19"), std::string::npos) << report.warnings[0];
  EXPECT_NE(report.warnings[0].find("S2.F.y"), std::string::npos) << report.warnings[0];
  EXPECT_FALSE(Exists(dir.path() / "figures" / "fig19-S2-reaction.png"));
  EXPECT_TRUE(Exists(dir.path() / "figures" / "fig18-S2-momentum.png"));
  EXPECT_FALSE(Exists(dir.path() / "figures" / "fig02-bond-graph.svg"));
  EXPECT_EQ(report.files.size(), 2 * (kContractNames.size() - 1));
}

TEST(PlotsTest, Errors) {
  TempDir dir;
  EXPECT_THROW(MakeFigures((dir.path() / "nothing").string()), std::runtime_error);
  EXPECT_THROW(WriteResultsPage((dir.path() / "nothing").string()), std::runtime_error);
  SyntheticRun().Write(dir.path());
  PlotOptions o = NoBondGraph();
  o.gnuplot = (dir.path() / "no-such-gnuplot").string();
  try {
    MakeFigures(dir.path().string(), o);
    ADD_FAILURE() << "no exception without gnuplot";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not installed"), std::string::npos) << e.what();
  }
  // The scripts are written all the same.
  EXPECT_TRUE(Exists(dir.path() / "plots" / "fig03-G-orientation.gp"));
}

// Each input is read once for the figures and the page, and each drawing made once: with
// results.csv gone once the inputs are read, every figure and the page are drawn (gnuplot reads the
// columns from its script, the page from the table read), and Graphviz runs once for the bond
// graph's PNG, SVG and the page's layout (a `dot` on the PATH that logs its runs).
TEST(PlotsTest, EachInputIsReadOnceAndTheBondGraphLaidOutOnce) {
  TempDir dir;
  const fs::path results = dir.path() / "run", bin = dir.path() / "bin", log = dir.path() / "dot-runs.log";
  fs::create_directory(results);
  SyntheticRun().Write(results);
  fs::create_directory(bin);
  std::ofstream(bin / "dot") << fmt::format("#!/bin/sh\necho \"$*\" >> '{}'\nexec /usr/bin/dot \"$@\"\n", log.string());
  fs::permissions(bin / "dot", fs::perms::owner_all);
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", (bin.string() + ":" + saved).c_str(), 1);

  const PlotInputs inputs(results.string(), Options());
  fs::remove(results / "results.csv");
  const PlotReport report = MakeFigures(inputs, Options());
  WriteResultsPage(inputs, report);
  setenv("PATH", saved.c_str(), 1);

  for (const std::string& w : report.warnings) ADD_FAILURE() << "warning: " << w;
  EXPECT_EQ(report.files.size(), 2 * PaperFigureNames().size());
  for (const std::string& name : PaperFigureNames())
    for (const char* ext : {".png", ".svg"}) EXPECT_TRUE(Exists(results / "figures" / (name + ext))) << name << ext;
  const std::string page = ReadFile(results / "index.html");
  EXPECT_THAT(page, HasSubstr(fmt::format("{} rows in results.csv", SyntheticRun::kRows)));
  EXPECT_THAT(page, HasSubstr("\"graph\":{\"bb\""));  // the bond graph, laid out
  const std::string runs = ReadFile(log);
  EXPECT_EQ(std::count(runs.begin(), runs.end(), '\n'), 1) << runs;
  EXPECT_THAT(runs, HasSubstr("-Tpng"));
  EXPECT_THAT(runs, HasSubstr("-Tsvg"));
  EXPECT_THAT(runs, HasSubstr("-Tjson"));
}

TEST(PlotsTest, PageShowsEveryFigureAndRendersInChromium) {
  TempDir dir;
  SyntheticRun().Write(dir.path());
  const PlotReport report = MakeFigures(dir.path().string(), Options());
  WriteResultsPage(dir.path().string(), report);
  const std::string html = ReadFile(dir.path() / "index.html");
  ASSERT_FALSE(html.empty());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  // Every figure file there is on the page, with the paper's caption.
  int figures = 0;
  for (const auto& entry : fs::directory_iterator(dir.path() / "figures")) {
    const std::string file = "figures/" + entry.path().filename().string();
    EXPECT_NE(html.find("\"" + file + "\""), std::string::npos) << file;
    ++figures;
  }
  EXPECT_EQ(figures, static_cast<int>(2 * PaperFigureNames().size()));
  EXPECT_NE(html.find("Fig. 16. Orientation matrix of link S2"), std::string::npos);
  EXPECT_NE(html.find("Fig. 28. Variation of coordinates of point Q<sub>P1</sub> on link P1 with time"), std::string::npos);
  EXPECT_NE(html.find("Fig. 2. Multibond graph model of Differential gear train mechanism"), std::string::npos);
  EXPECT_NE(html.find("twice the carrier"), std::string::npos);
  EXPECT_NE(html.find("Energy account"), std::string::npos);
  EXPECT_NE(html.find("synthetic"), std::string::npos);  // run.json read

  if (!fs::exists("/usr/bin/chromium")) GTEST_SKIP() << "/usr/bin/chromium is absent (Debian package chromium): page not rendered";
  const fs::path shot = dir.path() / "page.png", profile = dir.path() / "chromium-profile";
  fs::create_directories(profile);
  const std::string cmd = fmt::format(
      "timeout 120 /usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync --user-data-dir='{}' --screenshot='{}' "
      "--window-size=1280,2000 'file://{}' >'{}' 2>&1",
      profile.string(), shot.string(), (dir.path() / "index.html").string(), (dir.path() / "chromium.log").string());
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(rc, 0) << ReadFile(dir.path() / "chromium.log");
  ASSERT_TRUE(Exists(shot)) << ReadFile(dir.path() / "chromium.log");
  const std::string png = ReadFile(shot);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_GT(png.size(), 50000u) << "a blank page compresses to a few kB";
  // The screenshot has the window's size (IHDR: width and height, big-endian, at bytes 16 to 23).
  ASSERT_GE(png.size(), 24u);
  auto be32 = [&](size_t at) {
    return (static_cast<unsigned>(static_cast<unsigned char>(png[at])) << 24) | (static_cast<unsigned char>(png[at + 1]) << 16) |
           (static_cast<unsigned char>(png[at + 2]) << 8) | static_cast<unsigned char>(png[at + 3]);
  };
  EXPECT_EQ(be32(16), 1280u);
  EXPECT_EQ(be32(20), 2000u);
}

// ---------------------------------------------------------------------------------------------
// A results folder may come from anyone: its text never runs anything, plot reads only the
// folder's own regular files and writes only inside it, and malformed data is a clear error.

/// True when `s` is valid UTF-8 without control characters other than line breaks and tabs.
bool CleanText(const std::string& s) {
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7f) return false;
      ++i;
      continue;
    }
    const int n = (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : -1;
    if (n < 0) return false;
    for (int k = 1; k <= n; ++k)
      if (i + k >= s.size() || (static_cast<unsigned char>(s[i + k]) & 0xc0) != 0x80) return false;
    i += n + 1;
  }
  return true;
}


TEST(PlotsHostileTest, HeaderTextRunsNoCommandInGnuplot) {
  TempDir dir;
  SyntheticRun run;
  // Each unit tries another way out of a gnuplot string or comment; each would create a file
  // PWNED-<tag> in the folder (an absolute path: gnuplot may run elsewhere).
  const std::string marker = (dir.path() / "PWNED").string();
  auto touch = [&](const char* tag) { return fmt::format("touch {}-{}", marker, tag); };
  run.SetUnit("time", fmt::format("s`{}`\xff\xfe", touch("backquote")));
  run.SetUnit("G.h.x", fmt::format("N m s\nsystem \"{}\"\n!{}\n#", touch("newline-system"), touch("newline-bang")));
  run.SetUnit("G.h.y", fmt::format("@macro `{}` '); system('{}'); x=('", touch("quoted-backquote"), touch("single-quote")));
  run.SetUnit("drive.torque", fmt::format("N m\"; system \"{}\"; \"\\", touch("double-quote")));
  run.SetUnit("P1.r.x", fmt::format("m\\\n!{}", touch("continuation")));
  run.SetUnit("G.R.11", fmt::format("-\r!{}\x01\x1b[2J", touch("carriage-return")));
  run.Write(dir.path());

  const PlotReport report = MakeFigures(dir.path().string(), NoBondGraph());
  WriteResultsPage(dir.path().string(), report);
  for (const auto& entry : fs::directory_iterator(dir.path()))
    EXPECT_NE(entry.path().filename().string().rfind("PWNED", 0), 0u) << "a header's text ran a command: " << entry.path();
  // The figures with those columns are drawn all the same.
  for (const char* name : {"fig03-G-orientation", "fig05-G-momentum", "fig06-G-torque", "fig21-P1-com"})
    EXPECT_TRUE(Exists(dir.path() / "figures" / (std::string(name) + ".png"))) << name;
  // Every script is clean text; no file text leaves its line or reaches a backquote.
  for (const auto& entry : fs::directory_iterator(dir.path() / "plots")) {
    if (entry.path().extension() != ".gp") continue;
    const std::string gp = ReadFile(entry.path());
    EXPECT_TRUE(CleanText(gp)) << entry.path();
    EXPECT_EQ(gp.find('`'), std::string::npos) << entry.path();
    std::istringstream in(gp);
    for (std::string line; std::getline(in, line);) {
      const size_t first = line.find_first_not_of(' ');
      if (first == std::string::npos) continue;
      EXPECT_NE(line[first], '!') << entry.path() << ": " << line;
      EXPECT_NE(line.compare(first, 6, "system"), 0) << entry.path() << ": " << line;
    }
  }
  for (const std::string& w : report.warnings) EXPECT_TRUE(CleanText(w)) << w;
  EXPECT_TRUE(CleanText(ReadFile(dir.path() / "index.html")));
}

TEST(PlotsHostileTest, RunJsonIsARecordNotAnInstruction) {
  TempDir outer;
  const fs::path dir = outer.path() / "results";
  fs::create_directories(dir);
  // run.json names a file outside the folder whose text the loader would quote.
  const fs::path secret = outer.path() / "secret.yaml";
  std::ofstream(secret) << "SECRET-KEY-42: value\n";
  SyntheticRun().Write(dir);
  nlohmann::json run = nlohmann::json::parse(ReadFile(dir / "run.json"));
  run["model"]["file"] = secret.string();
  run["model"]["name"] = "</script><script>alert(1)</script>";
  run["status"] = "\"><img src=x onerror=alert(2)>";
  run["options"]["solver"] = "a & b 'c' `touch x`";
  std::ofstream(dir / "run.json") << run.dump();

  PlotOptions o;  // no --model: run.json's model.file is not followed
  o.figures_path = kPaperFigures;
  const PlotReport report = MakeFigures(dir.string(), o);
  WriteResultsPage(dir.string(), report);
  const std::string html = ReadFile(dir / "index.html");
  EXPECT_EQ(html.find("SECRET-KEY-42"), std::string::npos) << "a file named in run.json reached the page";
  for (const std::string& w : report.warnings) EXPECT_EQ(w.find("SECRET-KEY-42"), std::string::npos) << w;
  EXPECT_FALSE(Exists(dir / "figures" / "fig02-bond-graph.png"));
  bool said = false;
  for (const std::string& w : report.warnings) said = said || (w.find("run.json") != std::string::npos && w.find("--model") != std::string::npos);
  EXPECT_TRUE(said) << "no warning says that run.json's model is not opened and how to give one";
  // run.json's text is on the page, escaped.
  // The only script elements are the page's own: its data (JSON with '<' escaped) and its script.
  size_t scripts = 0;
  for (size_t at = html.find("<script"); at != std::string::npos; at = html.find("<script", at + 1)) {
    ++scripts;
    const std::string tag = html.substr(at, html.find('>', at) + 1 - at);
    EXPECT_TRUE(tag == "<script type=\"application/json\" id=\"mb-data\">" || tag == "<script src=\"multibond-page.js\">") << tag;
  }
  EXPECT_LE(scripts, 2u);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_NE(html.find("&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("&quot;&gt;&lt;img src=x onerror=alert(2)&gt;"), std::string::npos);
  EXPECT_NE(html.find("a &amp; b &#39;c&#39;"), std::string::npos);
}

TEST(PlotsHostileTest, ReadsOnlyRegularFilesOfTheFolder) {
  TempDir outer;
  const fs::path dir = outer.path() / "results", elsewhere = outer.path() / "elsewhere";
  fs::create_directories(dir);
  fs::create_directories(elsewhere);
  SyntheticRun().Write(elsewhere);
  // results.csv a link out of the folder.
  fs::create_symlink(elsewhere / "results.csv", dir / "results.csv");
  EXPECT_THAT(RuntimeErrorOf([&] { MakeFigures(dir.string(), NoBondGraph()); }), HasSubstr("symbolic link"));
  EXPECT_THAT(RuntimeErrorOf([&] { WriteResultsPage(dir.string()); }), HasSubstr("symbolic link"));
  EXPECT_FALSE(fs::exists(dir / "index.html"));
  // run.json a link out of the folder.
  fs::remove(dir / "results.csv");
  SyntheticRun().Write(dir);
  fs::remove(dir / "run.json");
  fs::create_symlink(elsewhere / "run.json", dir / "run.json");
  EXPECT_THAT(RuntimeErrorOf([&] { WriteResultsPage(dir.string()); }), HasSubstr("symbolic link"));
  // Not a regular file.
  fs::remove(dir / "run.json");
  fs::create_directories(dir / "run.json");
  EXPECT_THAT(RuntimeErrorOf([&] { WriteResultsPage(dir.string()); }), HasSubstr("not a regular file"));
}

TEST(PlotsHostileTest, WritesNothingThroughPlantedLinks) {
  TempDir outer;
  const fs::path dir = outer.path() / "results", elsewhere = outer.path() / "elsewhere";
  fs::create_directories(dir);
  fs::create_directories(elsewhere);
  SyntheticRun().Write(dir);
  const fs::path victim = elsewhere / "victim.txt";
  std::ofstream(victim) << "precious";

  // figures/ itself a link out of the folder: refused, nothing written there.
  fs::create_directory_symlink(elsewhere, dir / "figures");
  EXPECT_THAT(RuntimeErrorOf([&] { MakeFigures(dir.string(), NoBondGraph()); }), HasSubstr("symbolic link"));
  EXPECT_EQ(std::distance(fs::directory_iterator(elsewhere), fs::directory_iterator()), 1);
  fs::remove(dir / "figures");

  // Links in figures/ and plots/ where outputs go: replaced, never written through.
  fs::create_directories(dir / "figures");
  fs::create_directories(dir / "plots");
  const std::vector<fs::path> planted = {dir / "figures" / "fig05-G-momentum.png", dir / "figures" / "fig05-G-momentum.svg",
                                         dir / "plots" / "fig05-G-momentum.ranges", dir / "plots" / "fig05-G-momentum.gp",
                                         dir / "plots" / "fig05-G-momentum.log"};
  for (const fs::path& p : planted) fs::create_symlink(victim, p);
  const PlotReport report = MakeFigures(dir.string(), NoBondGraph());
  WriteResultsPage(dir.string(), report);
  EXPECT_EQ(ReadFile(victim), "precious");
  for (const fs::path& p : planted) {
    if (p.extension() == ".log") continue;  // written only when gnuplot complains
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(p))) << p;
  }
  EXPECT_EQ(ReadRanges(dir, "fig05-G-momentum").count("a"), 1u);
  // No temporaries are left in the folder.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_TRUE(entry.path().filename() == "results.csv" || entry.path().filename() == "run.json" ||
                entry.path().filename() == "figures" || entry.path().filename() == "plots" || entry.path().filename() == "index.html" ||
                entry.path().filename() == kPageScript || entry.path().filename() == kPageStyle)
        << entry.path();
}

TEST(PlotsHostileTest, MalformedResultsAreClearErrors) {
  TempDir dir;
  const fs::path csv = dir.path() / "results.csv";
  auto plot_error = [&] { return RuntimeErrorOf([&] { MakeFigures(dir.path().string(), NoBondGraph()); }); };
  auto page_error = [&] { return RuntimeErrorOf([&] { WriteResultsPage(dir.path().string()); }); };

  std::ofstream(csv, std::ios::trunc).flush();  // 0 bytes
  EXPECT_THAT(plot_error(), HasSubstr("empty"));
  EXPECT_THAT(page_error(), HasSubstr("empty"));

  {  // binary junk
    std::ofstream out(csv, std::ios::binary | std::ios::trunc);
    unsigned state = 12345;
    for (int i = 0; i < 200000; ++i) {
      state = state * 1103515245u + 12345u;
      out.put(static_cast<char>(state >> 16));
    }
  }
  EXPECT_FALSE(plot_error().empty());
  EXPECT_FALSE(page_error().empty());

  // Text where a number belongs: the line and the column.
  std::ofstream(csv, std::ios::trunc) << "time [s],x [m]\n0,1\n0.1,abc\n";
  EXPECT_THAT(plot_error(), HasSubstr("results.csv:3"));
  EXPECT_THAT(plot_error(), HasSubstr("not a number: 'abc' in column 2 ('x')"));
  // A row with too few values.
  std::ofstream(csv, std::ios::trunc) << "time [s],x [m]\n0,1\n0.1\n";
  EXPECT_THAT(plot_error(), HasSubstr("results.csv:3: 1 values for 2 columns"));
  // nan and inf are numbers: the figures are drawn or left out, nothing crashes.
  SyntheticRun nan_run;
  nan_run.SetValues("G.h.x", NAN);
  nan_run.SetValues("time", INFINITY, SyntheticRun::kRows - 1);
  nan_run.Write(dir.path());
  EXPECT_NO_THROW({
    try {
      WriteResultsPage(dir.path().string(), MakeFigures(dir.path().string(), NoBondGraph()));
    } catch (const std::runtime_error&) {
    }
  });
}

/// Runs MakePaperFigures on `dir` with 1.5 GB of address space (not under AddressSanitizer, which
/// reserves more) and exits 0 when it throws std::runtime_error saying `want`; 2 on another exception.
[[noreturn]] void ReadInLittleMemory(const fs::path& dir, const std::string& want) {
#if !defined(__SANITIZE_ADDRESS__)
  const rlimit limit{1536ull << 20, 1536ull << 20};
  setrlimit(RLIMIT_AS, &limit);
#endif
  int code = 1;
  try {
    PlotOptions o;
    o.bond_graph = false;
    MakeFigures(dir.string(), o);
  } catch (const std::runtime_error& e) {
    code = std::string(e.what()).find(want) != std::string::npos ? 0 : 3;
  } catch (...) {
    code = 2;
  }
  std::_Exit(code);
}

TEST(PlotsHostileTest, AMillionColumnsWithShortRowsStayInBoundedMemory) {
  TempDir dir;
  {
    std::ofstream out(dir.path() / "results.csv", std::ios::binary);
    out << "time [s]";
    for (int c = 1; c < 1000000; ++c) out << ",c" << c << " [m]";
    out << '\n';
    for (int r = 0; r < 2000; ++r) out << r << '\n';  // one value per row
  }
  // In a child with 1.5 GB of address space: a reader that pads short rows needs 16 GB.
  EXPECT_EXIT(ReadInLittleMemory(dir.path(), "1 values for 1000000 columns"), ::testing::ExitedWithCode(0), "");
}

// ---------------------------------------------------------------------------------------------
// The general figures: any results folder, through the CLI as a user runs it.

/// `multibond run EXAMPLE` then `multibond plot DIR`: exit 0, the figures `want` (PNG and SVG, each
/// with its script) and a page that shows them with the run's record.
void RunAndPlot(const std::string& example, const std::string& model_name, const std::vector<std::string>& want) {
  SCOPED_TRACE(example);
  TempDir tmp;
  const fs::path dir = tmp.path() / "results";
  const auto run = multibond::testing::RunCli(
      {"run", std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + example, "-o", dir.string(), "-q", "--jit", "off", "--t-end", "1"});
  ASSERT_EQ(run.code, 0) << run.out;
  const auto plot = multibond::testing::RunCli({"plot", dir.string()}, 120);
  ASSERT_EQ(plot.code, 0) << plot.out;
  EXPECT_EQ(plot.out.find("warning"), std::string::npos) << plot.out;
  const std::string html = ReadFile(dir / "index.html");
  for (const std::string& name : want) {
    for (const char* ext : {".png", ".svg"}) EXPECT_TRUE(Exists(dir / "figures" / (name + ext))) << name << ext;
    EXPECT_TRUE(Exists(dir / "plots" / (name + ".gp"))) << name;
    EXPECT_THAT(html, HasSubstr("<img src=\"figures/" + name + ".png\"")) << name;
  }
  // Nothing else is drawn: one figure per element and unit.
  size_t pictures = 0;
  for (const auto& entry : fs::directory_iterator(dir / "figures")) pictures += entry.path().extension() == ".png";
  EXPECT_EQ(pictures, want.size());
  // The run's record: model, options, solver statistics, status, energy.
  EXPECT_THAT(html, HasSubstr(model_name));
  EXPECT_THAT(html, HasSubstr("solver statistics"));
  EXPECT_THAT(html, HasSubstr("rhs_evals"));
  EXPECT_THAT(html, HasSubstr("<th>status</th><td>ok</td>"));
  EXPECT_THAT(html, HasSubstr("Energy account"));
  // The energy account's panels: work, kinetic, potential, dissipated in J, then the residual.
  const auto ranges = ReadRanges(dir, "energy-account");
  EXPECT_EQ(ranges.count("a"), 1u);
  EXPECT_EQ(ranges.count("b"), 1u);
  const std::string gp = ReadFile(dir / "plots" / "energy-account.gp");
  for (const char* c : {"energy.work [J]", "energy.kinetic [J]", "energy.potential [J]", "energy.dissipated [J]", "energy.residual [-]"})
    EXPECT_THAT(gp, HasSubstr(c));
}

TEST(PlotsGeneralTest, MassSpringDamper) {
  RunAndPlot("mass_spring_damper.yaml", "mass_spring_damper",
             {"energy-account", "mass-N_s", "spring-m", "force-J", "damper-J", "outputs-m_s", "outputs-N", "mass-J", "spring-J"});
}

TEST(PlotsGeneralTest, DcMotor) {
  RunAndPlot("dc_motor.yaml", "dc_motor",
             {"energy-account", "La-V_s", "J-N_m_s", "supply-J", "Ra-J", "friction-J", "outputs-A", "outputs-rad_s", "outputs-N_m",
              "La-J", "J-J"});
}

TEST(PlotsGeneralTest, TenThousandColumnsDrawABoundedNumberOfFigures) {
  TempDir dir;
  {
    std::ofstream out(dir.path() / "results.csv");
    out << "time [s]";
    for (int c = 0; c < 10000; ++c) out << ",e" << c << ".q [m]";
    out << '\n';
    for (int r = 0; r < 20; ++r) {
      out << 0.1 * r;
      for (int c = 0; c < 10000; ++c) out << ',' << (r + c) % 7;
      out << '\n';
    }
  }
  PlotOptions o;
  o.max_figures = 6;
  const auto start = std::chrono::steady_clock::now();
  const PlotReport report = MakeFigures(dir.path().string(), o);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 60.0);
  EXPECT_EQ(report.files.size(), 2u * 6u);
  size_t scripts = 0;
  for (const auto& entry : fs::directory_iterator(dir.path() / "plots")) scripts += entry.path().extension() == ".gp";
  EXPECT_EQ(scripts, 6u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_THAT(report.warnings[0], HasSubstr("9994 of 10000 figures left out"));
  EXPECT_THAT(report.warnings[0], HasSubstr("--max-figures"));
  // The default bound holds too.
  EXPECT_GT(PlotOptions{}.max_figures, 0u);
  EXPECT_LE(PlotOptions{}.max_figures, 200u);
  // One element of many columns: split into figures of a few curves.
  std::vector<std::string> names = {"time"}, units = {"s"}, warnings;
  for (int c = 0; c < 100; ++c) names.push_back(fmt::format("big.c{}", c)), units.push_back("m");
  EXPECT_EQ(FigureNames(AutoFigures(names, units, 100, warnings)).size(), (100 + kMaxCurvesPerFigure - 1) / kMaxCurvesPerFigure);
}

// A figure list is untrusted like a model file: its texts reach gnuplot only as escaped strings.
TEST(PlotsHostileTest, FigureListTextRunsNoCommandInGnuplot) {
  TempDir dir;
  SyntheticRun().Write(dir.path());
  const std::string marker = (dir.path() / "PWNED").string();
  const fs::path list = dir.path() / "list.yaml";
  std::ofstream(list) << fmt::format(R"(title: "<script>alert(1)</script>"
figures:
  - name: f1
    label: "`touch {0}-label`"
    caption: "'); system('touch {0}-caption'); x=('"
    shows: "<img src=x onerror=alert(2)> {{{{last G.h.x}}}}"
    panels:
      - title: "\"; system \"touch {0}-title\"; \""
        quantity: "@x `touch {0}-quantity`"
        unit: "\\\\\n!touch {0}-unit"
        curves: [{{vector: G.h, title: "\n!touch {0}-legend"}}]
)",
                                     marker);
  PlotOptions o;
  o.figures_path = list.string();
  const PlotReport report = MakeFigures(dir.path().string(), o);
  WriteResultsPage(dir.path().string(), report);
  for (const std::string& w : report.warnings) ADD_FAILURE() << w;
  EXPECT_TRUE(Exists(dir.path() / "figures" / "f1.png"));
  for (const auto& entry : fs::directory_iterator(dir.path()))
    EXPECT_NE(entry.path().filename().string().rfind("PWNED", 0), 0u) << "a figure list's text ran a command: " << entry.path();
  const std::string gp = ReadFile(dir.path() / "plots" / "f1.gp");
  EXPECT_EQ(gp.find('`'), std::string::npos);
  const std::string html = ReadFile(dir.path() / "index.html");
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_THAT(html, HasSubstr("&lt;img src=x onerror=alert(2)&gt;"));
}

// ---------------------------------------------------------------------------------------------
// Events (events.csv): a line at each event's time on every plot against time, a table on the page.

/// A small results folder (results.csv of two elements over [0, 2] s, run.json) with `events`
/// (events.csv's text, none when empty).
void WriteEventsRun(const fs::path& dir, const std::string& events) {
  {
    std::ofstream csv(dir / "results.csv");
    csv << "time [s],mass.p [N s],spring.q [m],velocity [m/s]\n";
    for (int r = 0; r <= 200; ++r) csv << fmt::format("{},{},{},{}\n", r * 0.01, std::sin(r * 0.05), std::cos(r * 0.05), r * 0.001);
  }
  std::ofstream(dir / "run.json") << R"({"model": {"name": "events"}, "status": "ok"})";
  if (!events.empty()) std::ofstream(dir / "events.csv") << events;
}

/// The .gp scripts of a results folder, by name.
std::map<std::string, std::string> Scripts(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& entry : fs::directory_iterator(dir / "plots"))
    if (entry.path().extension() == ".gp") out[entry.path().stem().string()] = ReadFile(entry.path());
  return out;
}

TEST(PlotsEventsTest, EveryTimePlotMarksTheEventsAndThePageListsThem) {
  TempDir dir;
  const std::string marker = (dir.path() / "PWNED").string();
  // Hostile element names and descriptions: quotes, markup, line breaks, gnuplot's backquotes and @macros.
  const std::string element = fmt::format("wall\"\n!touch {0}-bang\nsystem \"touch {0}-system\" `touch {0}-bq` @m <script>", marker);
  const std::string description = fmt::format("</td><script>alert(1)</script>'); system('touch {}-q')", marker);
  WriteEventsRun(dir.path(), "time [s],kind,element,description\n" +
                                 fmt::format("0.5,impact,{},{}\n", CsvCell(element), CsvCell(description)) +
                                 "1.25,time,src,a source's value jumps\n1.5,slip,friction,\"the force 5.886, at the limit\"\n");
  const PlotReport report = MakeFigures(dir.path().string());
  WriteResultsPage(dir.path().string(), report);
  for (const std::string& w : report.warnings) ADD_FAILURE() << w;
  for (const auto& entry : fs::directory_iterator(dir.path()))
    EXPECT_NE(entry.path().filename().string().rfind("PWNED", 0), 0u) << "an event's text ran a command: " << entry.path();
  const auto scripts = Scripts(dir.path());
  EXPECT_EQ(scripts.size(), 3u);  // mass-N_s, spring-m, outputs-m_s
  for (const auto& [name, gp] : scripts) {
    SCOPED_TRACE(name);
    EXPECT_TRUE(Exists(dir.path() / "figures" / (name + ".png")));
    EXPECT_FALSE(fs::exists(dir.path() / "plots" / (name + ".log"))) << "gnuplot said something: " << ReadFile(dir.path() / "plots" / (name + ".log"));
    EXPECT_THAT(gp, HasSubstr("set arrow from first 0.5, graph 0 to first 0.5, graph 1 nohead back lw 1 lc rgb \"#b2182b\" dt 1\n"));
    EXPECT_THAT(gp, HasSubstr("set arrow from first 1.25, graph 0 to first 1.25, graph 1 nohead back lw 1 lc rgb \"#a0a0a0\" dt 3\n"));
    EXPECT_THAT(gp, HasSubstr("set arrow from first 1.5, graph 0 to first 1.5, graph 1 nohead back lw 1 lc rgb \"#e08214\" dt 2\n"));
    EXPECT_THAT(gp, HasSubstr("title 'impact (1)'"));
    EXPECT_THAT(gp, HasSubstr("title 'slip (1)'"));
    EXPECT_THAT(gp, HasSubstr("title 'time (1)'"));
    EXPECT_EQ(gp.find('`'), std::string::npos);
    EXPECT_EQ(gp.find("<script>"), std::string::npos);  // descriptions stay out of the scripts
    std::istringstream in(gp);
    for (std::string line; std::getline(in, line);) {
      const size_t first = line.find_first_not_of(' ');
      if (first == std::string::npos) continue;
      EXPECT_NE(line[first], '!') << line;
      EXPECT_NE(line.compare(first, 6, "system"), 0) << line;
    }
  }
  const std::string html = ReadFile(dir.path() / "index.html");
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(html.find("</td><script"), std::string::npos);
  EXPECT_THAT(html, HasSubstr("Events (events.csv): 3 &mdash;"));
  EXPECT_THAT(html, HasSubstr("&lt;/td&gt;&lt;script&gt;alert(1)&lt;/script&gt;&#39;); system(&#39;touch"));
  EXPECT_THAT(html, HasSubstr("<td>the force 5.886, at the limit</td>"));
}

TEST(PlotsEventsTest, AMalformedEventsFileIsAWarningAndTheFiguresAreDrawn) {
  TempDir dir;
  WriteEventsRun(dir.path(), "time [s],kind,element,description\n0.5,impact,wall,x\n0.7,bounce,wall,y\n");
  const PlotReport report = MakeFigures(dir.path().string());
  WriteResultsPage(dir.path().string(), report);
  const std::string want = fmt::format("{}:3: unknown kind 'bounce'; the kinds are impact, contact, separation, stick, slip, lock, unlock, "
                                       "limit, time; the events are not marked",
                                       (dir.path() / "events.csv").string());
  EXPECT_EQ(report.warnings, std::vector<std::string>{want});
  for (const auto& [name, gp] : Scripts(dir.path())) {
    EXPECT_TRUE(Exists(dir.path() / "figures" / (name + ".png"))) << name;
    EXPECT_EQ(gp.find("nohead"), std::string::npos) << name;
  }
  const std::string html = ReadFile(dir.path() / "index.html");
  EXPECT_THAT(html, HasSubstr("unknown kind &#39;bounce&#39;"));
  EXPECT_EQ(html.find("Events (events.csv)"), std::string::npos);
  // The page said so once, though it reads events.csv again.
  EXPECT_EQ(html.find("unknown kind"), html.rfind("unknown kind"));
}

TEST(PlotsEventsTest, WithoutEventsNothingChanges) {
  TempDir with, without;
  WriteEventsRun(with.path(), "time [s],kind,element,description\n0.5,impact,wall,x\n");
  WriteEventsRun(without.path(), "");
  for (const fs::path& dir : {with.path(), without.path()}) WriteResultsPage(dir.string(), MakeFigures(dir.string()));
  const auto marked = Scripts(with.path()), plain = Scripts(without.path());
  ASSERT_EQ(marked.size(), plain.size());
  for (const auto& [name, gp] : plain) {
    EXPECT_EQ(gp.find("nohead"), std::string::npos) << name;
    // The script with events is the plain one with the marks added, and nothing else changed.
    std::string stripped;
    std::istringstream in(marked.at(name));
    for (std::string line; std::getline(in, line);) {
      const bool comment = line == "  # 1 event (events.csv)" || line == "  # impact: wall";
      if (comment || line.find("set arrow from first") != std::string::npos) continue;
      if (line.find("NaN with lines") != std::string::npos) {
        const std::string continued = ", \\\n";  // the line before went on to this one
        if (stripped.size() >= continued.size() && stripped.compare(stripped.size() - continued.size(), continued.size(), continued) == 0)
          stripped.replace(stripped.size() - continued.size(), continued.size(), "\n");
        continue;
      }
      stripped += line + "\n";
    }
    EXPECT_EQ(stripped, gp) << name;
  }
  EXPECT_EQ(ReadFile(without.path() / "index.html").find("events.csv"), std::string::npos);
}

// Through the CLI: the clutch locks at t = 1.6 s (examples/events/clutch.yaml); its plots show it.
TEST(PlotsEventsTest, ClutchThroughTheCli) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "results";
  const auto run = multibond::testing::RunCli(
      {"run", std::string(MULTIBOND_SOURCE_DIR) + "/examples/events/clutch.yaml", "-o", dir.string(), "-q", "--jit", "off"});
  ASSERT_EQ(run.code, 0) << run.out;
  ASSERT_TRUE(Exists(dir / "events.csv"));
  const auto plot = multibond::testing::RunCli({"plot", dir.string()}, 120);
  ASSERT_EQ(plot.code, 0) << plot.out;
  EXPECT_EQ(plot.out.find("warning"), std::string::npos) << plot.out;
  EXPECT_EQ(ReadFile(dir / "figures" / "outputs-rad_s.png").substr(1, 3), "PNG");
  const std::string gp = ReadFile(dir / "plots" / "outputs-rad_s.gp");
  // The lock where the speeds meet, 0.1 + 100 / (50 + 50/3) = 1.6 s, and the engagement at 0.1 s.
  const size_t at = gp.find("lc rgb \"#1b7837\" dt 4\n");
  ASSERT_NE(at, std::string::npos) << gp;
  const size_t from = gp.rfind("set arrow from first ", at) + std::string("set arrow from first ").size();
  EXPECT_NEAR(std::stod(gp.substr(from)), 1.6, 1e-6);
  EXPECT_THAT(gp, HasSubstr("title 'lock (1)'"));
  EXPECT_THAT(gp, HasSubstr("set arrow from first 0.10000000000000001, graph 0"));
  EXPECT_THAT(ReadFile(dir / "index.html"), HasSubstr("lock</td><td>clutch</td>"));
}

}  // namespace
}  // namespace multibond
