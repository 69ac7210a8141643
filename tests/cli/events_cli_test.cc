// Events on the command line: events.csv and run.json's counts, the Zeno warning, an event storm
// (exit 2, the results kept), --event-rest-time and --max-events-per-second and the model file's
// keys event_rest_time and max_events_per_second.


#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using multibond::testing::ReadFile;

struct Result {
  int code;
  std::string out;  // stdout and stderr together
  std::string err;  // stderr alone
};

/// Runs the CLI with `args` (split at spaces, no shell); stdout then stderr, and stderr alone.
Result Cli(const std::string& args, const fs::path& err_file) {
  std::vector<std::string> argv = multibond::testing::SplitArgs(args);
  argv.insert(argv.begin(), MULTIBOND_CLI);
  const multibond::testing::CliResult r = multibond::testing::RunProgram(argv, 600, "", err_file.string());
  return {r.code, r.out + r.err, r.err};
}

std::string Example(const std::string& name) { return std::string(MULTIBOND_SOURCE_DIR) + "/examples/" + name; }

struct EventRow {
  double time;
  std::string kind, element;
};

/// events.csv: the header line and the rows (time, kind, element; the description is not read).
std::pair<std::string, std::vector<EventRow>> ReadEvents(const fs::path& p) {
  std::istringstream in(ReadFile(p));
  std::string header, line;
  std::getline(in, header);
  std::vector<EventRow> rows;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string time, kind, element;
    std::getline(fields, time, ',');
    std::getline(fields, kind, ',');
    std::getline(fields, element, ',');
    rows.push_back({std::stod(time), kind, element});
  }
  return {header, rows};
}

/// The bouncing ball's closed form (examples/events/bouncing_ball.yaml): the first impact at
/// t1 = sqrt(2 h0 / g); the rebound after the k-th impact (k = 1, 2, ...) flies 2 e^k v1 / g.
constexpr double kG = 9.81, kH0 = 1.0, kRestitution = 0.8;
const double kV1 = std::sqrt(2 * kG * kH0), kT1 = std::sqrt(2 * kH0 / kG);
double Flight(int k) { return 2 * std::pow(kRestitution, k) * kV1 / kG; }
/// The impacts the ball rebounds from when a rebound that would fly less than `rest_time` is not
/// flown: the contact closes at the impact after them.
int ImpactsWithRestTime(double rest_time) {
  int impacts = 0;
  while (Flight(impacts + 1) >= rest_time) ++impacts;
  return impacts;
}
/// When the ball comes to rest after `impacts` rebounds.
double RestingTime(int impacts) {
  double t = kT1;
  for (int k = 1; k <= impacts; ++k) t += Flight(k);
  return t;
}

class EventsCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("multibond_events_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  Result Run(const std::string& args) const { return Cli(args, dir_ / "stderr.txt"); }
  /// `run MODEL -o dir_/out ARGS --jit off`.
  Result RunModel(const std::string& model, const std::string& args, const std::string& out = "out") const {
    return Run("run " + model + " -o " + (dir_ / out).string() + " --jit off " + args);
  }
  nlohmann::json RunJson(const std::string& out = "out") const { return nlohmann::json::parse(ReadFile(dir_ / out / "run.json")); }
  /// A copy of the bouncing ball whose simulation section is `simulation`.
  fs::path BallWithSimulation(const std::string& simulation) const {
    std::string text = ReadFile(Example("events/bouncing_ball.yaml"));
    const std::string settings = "simulation: {t_end: 10, dt: 1.0e-3, rtol: 1.0e-10, atol: 1.0e-12}";
    const size_t at = text.find(settings);
    EXPECT_NE(at, std::string::npos);
    if (at != std::string::npos) text.replace(at, settings.size(), simulation);
    const fs::path p = dir_ / "ball.yaml";
    std::ofstream(p) << text;
    return p;
  }
  fs::path dir_;
};

// The ball's impacts and its rest, each a row of events.csv in time order, as run.json counts
// them; the rest (Zeno) said on the terminal and in run.json's warnings.
TEST_F(EventsCliTest, BouncingBallWritesEventsCsvAsRunJsonCountsThem) {
  const Result r = RunModel(Example("events/bouncing_ball.yaml"), "-q");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(fs::exists(dir_ / "out" / "events.csv"));
  const auto [header, rows] = ReadEvents(dir_ / "out" / "events.csv");
  EXPECT_EQ(header, "time [s],kind,element,description");
  ASSERT_FALSE(rows.empty());
  std::map<std::string, long> by_kind;
  for (size_t i = 0; i < rows.size(); ++i) {
    ++by_kind[rows[i].kind];
    EXPECT_EQ(rows[i].element, "ground") << "row " << i + 1;
    if (i > 0) {
      EXPECT_GT(rows[i].time, rows[i - 1].time) << "row " << i + 1;
    }
  }
  EXPECT_EQ(std::set<std::string>({"contact", "impact"}), [&] {
    std::set<std::string> kinds;
    for (const auto& [kind, count] : by_kind) kinds.insert(kind);
    return kinds;
  }());
  // The first event is the first impact, at sqrt(2 h0 / g).
  EXPECT_EQ(rows.front().kind, "impact");
  EXPECT_NEAR(rows.front().time, kT1, 1e-7);

  const auto run = RunJson();
  EXPECT_EQ(run["status"], "ok");
  EXPECT_EQ(run["events"]["count"].get<long>(), static_cast<long>(rows.size()));
  for (const auto& [kind, count] : by_kind) EXPECT_EQ(run["events"]["by_kind"][kind].get<long>(), count) << kind;
  EXPECT_EQ(run["events"]["by_kind"].size(), by_kind.size());
  EXPECT_EQ(run["options"]["event_rest_time"].get<double>(), 0.0);
  EXPECT_EQ(run["options"]["max_events_per_second"].get<double>(), 1e4);

  // The ball comes to rest (Zeno) near the accumulation time t1 + 2 e v1 / (g (1 - e)) = 4.0637 s,
  // the last event: a warning on stderr, and the same in run.json.
  EXPECT_EQ(rows.back().kind, "contact");
  EXPECT_EQ(by_kind["contact"], 1);
  EXPECT_NEAR(rows.back().time, kT1 + 2 * kRestitution * kV1 / (kG * (1 - kRestitution)), 1e-4);
  ASSERT_EQ(run["warnings"].size(), 1u) << run["warnings"].dump();
  const std::string warning = run["warnings"][0].get<std::string>();
  EXPECT_THAT(warning, HasSubstr("contact 'ground': impacts accumulated (Zeno)"));
  EXPECT_THAT(warning, HasSubstr("after " + std::to_string(by_kind["impact"]) + " impacts"));
  EXPECT_THAT(r.err, HasSubstr("warning: " + warning + "\n"));
}

// A larger rest time ends the bouncing sooner: fewer impacts, an earlier rest, as the closed form
// counts the rebounds that fly at least that long.
TEST_F(EventsCliTest, EventRestTimeDecidesWhenTheBallRests) {
  std::map<double, std::pair<long, double>> impacts_and_rest;  // rest time -> (impacts, the time of the contact)
  for (const double rest_time : {0.05, 0.2}) {
    const std::string out = "rest" + std::to_string(rest_time);
    const Result r = RunModel(Example("events/bouncing_ball.yaml"), "-q --event-rest-time " + std::to_string(rest_time), out);
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(RunJson(out)["options"]["event_rest_time"].get<double>(), rest_time);
    const std::vector<EventRow> rows = ReadEvents(dir_ / out / "events.csv").second;
    ASSERT_FALSE(rows.empty());
    const long impacts = std::count_if(rows.begin(), rows.end(), [](const EventRow& e) { return e.kind == "impact"; });
    EXPECT_EQ(impacts, ImpactsWithRestTime(rest_time)) << "rest time " << rest_time;
    EXPECT_EQ(rows.back().kind, "contact");
    EXPECT_NEAR(rows.back().time, RestingTime(ImpactsWithRestTime(rest_time)), 1e-6) << "rest time " << rest_time;
    EXPECT_THAT(r.err, HasSubstr("came to rest at t = ")) << "rest time " << rest_time;
    EXPECT_THAT(r.err, HasSubstr("after " + std::to_string(impacts) + " impacts")) << "rest time " << rest_time;
    impacts_and_rest[rest_time] = {impacts, rows.back().time};
  }
  EXPECT_EQ(ImpactsWithRestTime(0.2), 6);  // rebounds of 0.72, 0.58, 0.46, 0.37, 0.30 and 0.24 s; the next 0.19 s
  EXPECT_EQ(ImpactsWithRestTime(0.05), 12);
  EXPECT_LT(impacts_and_rest[0.2].first, impacts_and_rest[0.05].first);
  EXPECT_LT(impacts_and_rest[0.2].second, impacts_and_rest[0.05].second);
}

// Stick-slip switches about 2.5 times a second (stick 0.3924 s, slip 0.4084 s): over 1000 s about
// 2,500 events. A limit of 2 per second (2,000 events) stops the run as an event storm, exit 2,
// with the results and events up to then kept and run.json marking it failed; 3 per second
// (3,000) lets it finish.
TEST_F(EventsCliTest, AnEventStormStopsTheRunKeepingItsResults) {
  const std::string args = "-q --t-end 1000 --dt 0.5";
  const Result storm = RunModel(Example("events/stick_slip.yaml"), args + " --max-events-per-second 2", "storm");
  EXPECT_EQ(storm.code, 2) << storm.out;
  EXPECT_THAT(storm.err, HasSubstr("event storm"));
  EXPECT_THAT(storm.err, HasSubstr("--max-events-per-second"));
  EXPECT_THAT(storm.err, HasSubstr("the results up to then are kept"));
  const auto run = RunJson("storm");
  EXPECT_EQ(run["status"], "failed");
  EXPECT_THAT(run["message"].get<std::string>(), HasSubstr("event storm"));
  const auto [header, rows] = ReadEvents(dir_ / "storm" / "events.csv");
  EXPECT_EQ(run["events"]["count"].get<long>(), static_cast<long>(rows.size()));
  EXPECT_GT(rows.size(), 2000u);
  EXPECT_LT(rows.size(), 2010u);
  // Stopped about 2,000 events in: at about 800 s of the 1000.
  EXPECT_GT(rows.back().time, 780.0);
  EXPECT_LT(rows.back().time, 820.0);
  EXPECT_TRUE(fs::exists(dir_ / "storm" / "results.csv"));
  EXPECT_GT(ReadFile(dir_ / "storm" / "results.csv").size(), 1000u);

  const Result ok = RunModel(Example("events/stick_slip.yaml"), args + " --max-events-per-second 3", "ok");
  EXPECT_EQ(ok.code, 0) << ok.out;
  const auto run_ok = RunJson("ok");
  EXPECT_EQ(run_ok["status"], "ok");
  // Two switches per period of 0.800844 s.
  EXPECT_NEAR(run_ok["events"]["count"].get<double>(), 2 * 1000 / 0.800844, 3.0);
}

// A table of a million rows (#44: every documented raise led to the next wall, the last an event
// storm of a restart per row): the size limits' hints name the raise that is needed, one after the
// other, and with both raises it runs, restarting only where the sampled sine turns.
TEST_F(EventsCliTest, AMillionRowTableRunsWithTheRaisesItsHintsName) {
  const fs::path model = dir_ / "dense.yaml";
  constexpr int n = 1000001;
  constexpr double w = 2 * 3.14159265358979323846;
  {
    std::ofstream f(model);
    f << "model: dense_table\ndomain: electrical\nelements:\n  src: {type: Se, effort: {table: [";
    for (int i = 0; i < n; ++i) {
      const double t = 10.0 * i / (n - 1);
      f << (i ? "," : "") << "[" << fmt::format("{:.8g}", t) << "," << fmt::format("{:.8g}", std::sin(w * t)) << "]";
    }
    f << "]}}\n  L: {type: I, inertia: 1.0}\n  R: {type: R, resistance: 1.0}\n  j: {type: \"1\"}\n"
         "bonds: [src -> j, j -> L, j -> R]\nsimulation: {t_end: 10, dt: 0.01}\n";
  }
  ASSERT_GT(fs::file_size(model), 16u << 20);  // above the default file-size limit
  const Result big = RunModel(model.string(), "-q", "big");
  EXPECT_EQ(big.code, 1) << big.err;
  EXPECT_THAT(big.err, HasSubstr("--limit file-size="));
  const Result nodes = RunModel(model.string(), "-q --limit file-size=32M", "nodes");
  EXPECT_EQ(nodes.code, 1) << nodes.err;
  EXPECT_THAT(nodes.err, HasSubstr("--limit yaml-nodes="));
  const Result ok = RunModel(model.string(), "-q --limit file-size=32M --limit yaml-nodes=4M", "ok");
  ASSERT_EQ(ok.code, 0) << ok.err;
  const auto run = RunJson("ok");
  EXPECT_EQ(run["status"], "ok");
  EXPECT_GE(run["events"]["count"].get<int>(), 20);  // two turning points a period, and no more than a few each
  EXPECT_LE(run["events"]["count"].get<int>(), 100);
  // i = (sin(w t) - w cos(w t) + w e^-t) / (1 + w^2) at t = 10 s.
  const std::string csv = ReadFile(dir_ / "ok" / "results.csv");
  const std::string last = csv.substr(csv.rfind('\n', csv.size() - 2) + 1);
  const double p = std::stod(last.substr(last.find(',') + 1));
  EXPECT_NEAR(p, (std::sin(w * 10) - w * std::cos(w * 10) + w * std::exp(-10.0)) / (1 + w * w), 5e-8) << last;
}

// A run without events writes no events.csv, and removes the one an earlier run left in the folder.
TEST_F(EventsCliTest, ARunWithoutEventsLeavesNoEventsCsv) {
  ASSERT_EQ(RunModel(Example("mass_spring_damper.yaml"), "-q --t-end 0.1", "plain").code, 0);
  EXPECT_FALSE(fs::exists(dir_ / "plain" / "events.csv"));
  EXPECT_EQ(RunJson("plain")["events"]["count"].get<long>(), 0);

  ASSERT_EQ(RunModel(Example("events/bouncing_ball.yaml"), "-q --t-end 1").code, 0);
  ASSERT_TRUE(fs::exists(dir_ / "out" / "events.csv"));
  const Result r = RunModel(Example("mass_spring_damper.yaml"), "-q --t-end 0.1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "events.csv")) << "an earlier run's events.csv was left beside these results";
  EXPECT_EQ(RunJson()["events"]["count"].get<long>(), 0);
}

// The model file's keys, under the command line.
TEST_F(EventsCliTest, TheModelFilesEventSettingsYieldToTheCommandLine) {
  const fs::path model =
      BallWithSimulation("simulation: {t_end: 10, dt: 1.0e-3, rtol: 1.0e-10, atol: 1.0e-12, event_rest_time: 0.2, max_events_per_second: 500}");
  ASSERT_EQ(RunModel(model.string(), "-q", "file").code, 0);
  auto run = RunJson("file");
  EXPECT_EQ(run["options"]["event_rest_time"].get<double>(), 0.2);
  EXPECT_EQ(run["options"]["max_events_per_second"].get<double>(), 500.0);
  EXPECT_EQ(run["events"]["by_kind"]["impact"].get<int>(), ImpactsWithRestTime(0.2));

  ASSERT_EQ(RunModel(model.string(), "-q --event-rest-time 0.05 --max-events-per-second 700", "cli").code, 0);
  run = RunJson("cli");
  EXPECT_EQ(run["options"]["event_rest_time"].get<double>(), 0.05);
  EXPECT_EQ(run["options"]["max_events_per_second"].get<double>(), 700.0);
  EXPECT_EQ(run["events"]["by_kind"]["impact"].get<int>(), ImpactsWithRestTime(0.05));
}

// Bad values: a usage error (64) on the command line, before anything is written, for `run` and
// the other commands with the run options; a located model error in the file.
TEST_F(EventsCliTest, BadEventSettingsAreRefused) {
  for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
           {"--event-rest-time -1", "must be >= 0 (got -1)"},
           {"--event-rest-time soon", "'soon' is not a number"},
           {"--event-rest-time inf", "must be a finite number"},
           {"--max-events-per-second 0", "must be > 0 (got 0)"},
           {"--max-events-per-second -5", "must be > 0 (got -5)"},
           {"--max-events-per-second many", "'many' is not a number"}}) {
    const Result r = RunModel(Example("events/bouncing_ball.yaml"), args, "bad");
    EXPECT_EQ(r.code, 64) << args << ": " << r.out;
    EXPECT_THAT(r.out, HasSubstr(expected)) << args;
    EXPECT_FALSE(fs::exists(dir_ / "bad")) << args << " created the output folder";
    const Result c = Run("compare " + Example("events/bouncing_ball.yaml") + " " + Example("events/bouncing_ball.yaml") + " " + args);
    EXPECT_EQ(c.code, 64) << "compare " << args << ": " << c.out;
  }
  for (const auto& [setting, expected] : std::vector<std::pair<std::string, std::string>>{
           {"event_rest_time: -0.5", "event_rest_time must be >= 0 (got -0.5)"},
           {"max_events_per_second: 0", "max_events_per_second must be > 0 (got 0)"},
           {"max_events_per_second: .inf", "is not a finite number"}}) {
    const fs::path model = BallWithSimulation("simulation: {t_end: 10, " + setting + "}");
    for (const std::string& command : {"check " + model.string(), "run " + model.string() + " -o " + (dir_ / "bad").string()}) {
      const Result r = Run(command);
      EXPECT_EQ(r.code, 1) << command << ": " << r.out;
      EXPECT_THAT(r.out, HasSubstr("ball.yaml:")) << setting;
      EXPECT_THAT(r.out, HasSubstr(expected)) << setting;
      EXPECT_FALSE(fs::exists(dir_ / "bad")) << setting;
    }
  }
  // At the line and column of the value (the file's last line but one).
  const fs::path model = BallWithSimulation("simulation:\n  t_end: 10\n  event_rest_time: -0.5\n");
  const std::string text = ReadFile(model);
  const long line = std::count(text.begin(), text.end(), '\n') - 1;
  const Result r = Run("check " + model.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("ball.yaml:" + std::to_string(line) + ":20: error: simulation: event_rest_time must be >= 0 (got -0.5)"));
}

}  // namespace
