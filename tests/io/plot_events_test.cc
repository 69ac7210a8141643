// events.csv as plot reads it (RFC 4180 records, checked, bounded; a bad file a located warning and
// no events), and the gnuplot lines that mark the events on a time plot (thinned past a bound).
#include "multibond/io/plot_events.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "multibond/io/results_writer.h"
#include "support/errors.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::RuntimeErrorOf;

struct TempDir : multibond::testing::TempDir {
  TempDir() : multibond::testing::TempDir("multibond-plot-events-test") {}
};

constexpr const char* kHeader = "time [s],kind,element,description\n";

std::vector<PlotEvent> Parse(const std::string& text, size_t max = kMaxEvents, bool* more = nullptr) {
  std::istringstream in(text);
  return ParseEvents(in, "events.csv", max, more);
}

std::string ParseError(const std::string& text) {
  return RuntimeErrorOf([&] { Parse(text); });
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(PlotEventsTest, ReadsTheRecordsAsTheWriterQuotesThem) {
  // The cells as ResultsFiles writes them (CsvCell): commas, quotes and line breaks quoted.
  const std::string element = "a,b \"c\"\nd", description = "holding takes 1.962, within the static limit 5.886";
  const std::string text = std::string(kHeader) + "0.5,impact,ground,v -4 -> 3\n\n" +
                           fmt::format("{:.17g},stick,{},{}\r\n", 1.0 / 3, CsvCell(element), CsvCell(description)) + "2,time,src,\n";
  const std::vector<PlotEvent> e = Parse(text);
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[0].time, 0.5);
  EXPECT_EQ(e[0].kind, "impact");
  EXPECT_EQ(e[0].description, "v -4 -> 3");
  EXPECT_EQ(e[1].time, 1.0 / 3);  // every digit kept
  EXPECT_EQ(e[1].element, element);
  EXPECT_EQ(e[1].description, description);
  EXPECT_EQ(e[2].kind, "time");
  EXPECT_EQ(e[2].description, "");
}

TEST(PlotEventsTest, MalformedFilesAreLocatedErrors) {
  EXPECT_EQ(ParseError(""), "events.csv:1: empty file: expected the header time [s],kind,element,description");
  EXPECT_EQ(ParseError("time,kind\n1,impact\n"), "events.csv:1: the header is 'time,kind', not 'time [s],kind,element,description'");
  EXPECT_EQ(ParseError(std::string(kHeader) + "1,impact,a,b\n2,slid,a,b\n"), "events.csv:3: unknown kind 'slid' (did you mean 'slip'?)");
  EXPECT_THAT(ParseError(std::string(kHeader) + "1,explosion,a,b\n"), HasSubstr("events.csv:2: unknown kind 'explosion'; the kinds are impact,"));
  EXPECT_EQ(ParseError(std::string(kHeader) + "nan,impact,a,b\n"), "events.csv:2: the time 'nan' is not a finite number");
  EXPECT_EQ(ParseError(std::string(kHeader) + "1e999,impact,a,b\n"), "events.csv:2: the time '1e999' is not a finite number");
  EXPECT_EQ(ParseError(std::string(kHeader) + "1s,impact,a,b\n"), "events.csv:2: the time '1s' is not a finite number");
  EXPECT_EQ(ParseError(std::string(kHeader) + "1,impact,a\n"), "events.csv:2: 3 cells, expected 4: time, kind, element, description");
  EXPECT_THAT(ParseError(std::string(kHeader) + "1,impact,a,b,c\n"), HasSubstr("events.csv:2: more than 4 cells"));
  EXPECT_EQ(ParseError(std::string(kHeader) + "1,impact,a,\"b\nc\n"), "events.csv:2: a quoted cell is not closed");
  EXPECT_EQ(ParseError(std::string(kHeader) + "1,impact,a,\"b\nc\"x\n"), "events.csv:3: text after a quoted cell: 'x'");
  EXPECT_THAT(ParseError(std::string(kHeader) + "1,impact,a\"b,c\n"), HasSubstr("events.csv:2: a quote inside a cell"));
  // What is quoted in a message is printable.
  EXPECT_EQ(ParseError(std::string(kHeader) + "1,\x1b[2J,a,b\n"), "events.csv:2: unknown kind '\\x1b[2J'; the kinds are impact, contact, "
                                                                  "separation, stick, slip, lock, unlock, limit, time");
}

TEST(PlotEventsTest, ReadsAtMostMaxEvents) {
  std::string text = kHeader;
  for (int k = 0; k < 10; ++k) text += fmt::format("{},slip,f,x\n", k);
  bool more = true;
  EXPECT_EQ(Parse(text, 10, &more).size(), 10u);
  EXPECT_FALSE(more);
  const std::vector<PlotEvent> e = Parse(text, 4, &more);
  ASSERT_EQ(e.size(), 4u);
  EXPECT_EQ(e.back().time, 3.0);
  EXPECT_TRUE(more);
}

/// A results folder with events.csv holding `text` and run.json `run`.
void WriteFolder(const fs::path& dir, const std::string& text, const nlohmann::json& run = nlohmann::json::object()) {
  std::ofstream(dir / "events.csv") << text;
  std::ofstream(dir / "run.json") << run.dump();
}

TEST(PlotEventsTest, ReadPlotEventsGivesWarningsNotErrors) {
  TempDir dir;
  const ResultsFolder folder(dir.path().string());
  const std::string events_csv = (dir.path() / "events.csv").string();
  const std::string next = "0.5,unlock,c,y\n";
  // No events.csv: nothing, and nothing to say.
  PlotEvents e = ReadPlotEvents(folder, nlohmann::json::object());
  EXPECT_TRUE(e.events.empty());
  EXPECT_TRUE(e.warnings.empty());
  // run.json lists one that is not there.
  const std::string good = std::string(kHeader) + "0.25,lock,c,x\n";
  const nlohmann::json listed = {{"files", {{{"file", "events.csv"}, {"format", "events"}, {"bytes", good.size()}}}},
                                 {"events", {{"count", 1}}}};
  e = ReadPlotEvents(folder, listed);
  ASSERT_EQ(e.warnings.size(), 1u);
  EXPECT_EQ(e.warnings[0], fmt::format("run.json lists {}, but the folder has none: the events are not marked", events_csv));
  // The file of the run: its size, one event.
  WriteFolder(dir.path(), good);
  e = ReadPlotEvents(folder, listed);
  EXPECT_TRUE(e.warnings.empty()) << e.warnings[0];
  ASSERT_EQ(e.events.size(), 1u);
  EXPECT_EQ(e.events[0].time, 0.25);
  // Another file: its size and count differ from run.json's.
  WriteFolder(dir.path(), good + next);
  e = ReadPlotEvents(folder, listed);
  EXPECT_EQ(e.events.size(), 2u);
  ASSERT_EQ(e.warnings.size(), 2u);
  EXPECT_EQ(e.warnings[0], fmt::format("{} has {} bytes, run.json lists {}: it is not the file of the run; its events are marked as it has them",
                                       events_csv, good.size() + next.size(), good.size()));
  EXPECT_EQ(e.warnings[1], fmt::format("run.json counts 1 events, {} has 2: they are marked as the file has them", events_csv));
  // Malformed: no events, and a warning that says where and that they are not marked.
  WriteFolder(dir.path(), good + "0.5,unlcok,c,y\n");
  e = ReadPlotEvents(folder, nlohmann::json::object());
  EXPECT_TRUE(e.events.empty());
  ASSERT_EQ(e.warnings.size(), 1u);
  EXPECT_EQ(e.warnings[0], fmt::format("{}:3: unknown kind 'unlcok' (did you mean 'unlock'?); the events are not marked", events_csv));
  // A link, even to a good file: not read.
  fs::remove(dir.path() / "events.csv");
  const TempDir elsewhere;
  std::ofstream(elsewhere.path() / "events.csv") << good;
  fs::create_symlink(elsewhere.path() / "events.csv", dir.path() / "events.csv");
  e = ReadPlotEvents(folder, nlohmann::json::object());
  EXPECT_TRUE(e.events.empty());
  ASSERT_EQ(e.warnings.size(), 1u);
  EXPECT_THAT(e.warnings[0], HasSubstr("is a symbolic link"));
  EXPECT_THAT(e.warnings[0], HasSubstr("the events are not marked"));
  // A folder in its place.
  fs::remove(dir.path() / "events.csv");
  fs::create_directories(dir.path() / "events.csv");
  e = ReadPlotEvents(folder, nlohmann::json::object());
  ASSERT_EQ(e.warnings.size(), 1u);
  EXPECT_THAT(e.warnings[0], HasSubstr("not a regular file"));
}

TEST(PlotEventsTest, TooLargeAFileIsNotRead) {
  TempDir dir;
  {
    std::ofstream out(dir.path() / "events.csv");
    out << kHeader;
  }
  fs::resize_file(dir.path() / "events.csv", kMaxEventsBytes + 1);  // a sparse file
  const PlotEvents e = ReadPlotEvents(ResultsFolder(dir.path().string()), nlohmann::json::object());
  EXPECT_TRUE(e.events.empty());
  ASSERT_EQ(e.warnings.size(), 1u);
  EXPECT_THAT(e.warnings[0], HasSubstr(fmt::format("is {} bytes, more than the {} bytes plot reads; the events are not marked",
                                                   kMaxEventsBytes + 1, kMaxEventsBytes)));
}

TEST(PlotEventsTest, MarksAreLinesAtTheEventsTimesStyledByKind) {
  const std::vector<PlotEvent> events = {{0.5, "impact", "ground", ""}, {1.25, "time", "src", ""}, {1.5, "impact", "wall", ""}, {3.0, "slip", "f", ""}};
  const EventMarks m = GnuplotEventMarks(events, 0, 2);
  EXPECT_EQ(m.arrows,
            "  # 3 events (events.csv)\n"
            "  # impact: ground\n"
            "  set arrow from first 0.5, graph 0 to first 0.5, graph 1 nohead back lw 1 lc rgb \"#b2182b\" dt 1\n"
            "  # time: src\n"
            "  set arrow from first 1.25, graph 0 to first 1.25, graph 1 nohead back lw 1 lc rgb \"#a0a0a0\" dt 3\n"
            "  # impact: wall\n"
            "  set arrow from first 1.5, graph 0 to first 1.5, graph 1 nohead back lw 1 lc rgb \"#b2182b\" dt 1\n");
  // One key entry per kind present on this plot (the slip at t = 3 is not).
  EXPECT_EQ(m.keys,
            ", \\\n       NaN with lines lw 1 lc rgb \"#b2182b\" dt 1 title 'impact (2)'"
            ", \\\n       NaN with lines lw 1 lc rgb \"#a0a0a0\" dt 3 title 'time (1)'");
  // Nothing in the window: nothing at all.
  const EventMarks none = GnuplotEventMarks(events, 4, 5);
  EXPECT_EQ(none.arrows, "");
  EXPECT_EQ(none.keys, "");
  // Every kind has its own colour or dash, and time events are drawn lighter.
  std::set<std::pair<std::string, int>> looks;
  for (const EventStyle& s : EventStyles()) looks.insert({s.color, s.dash});
  EXPECT_EQ(looks.size(), EventStyles().size());
  EXPECT_EQ(std::string(FindEventStyle("time")->color), "#a0a0a0");
  EXPECT_EQ(FindEventStyle("bogus"), nullptr);
}

TEST(PlotEventsTest, ManyEventsAreThinnedToOneLineABin) {
  // 10,000 slips over [0, 10] and one impact: at most 200 lines, the impact's bin shows it.
  std::vector<PlotEvent> events;
  for (int k = 0; k < 10000; ++k) events.push_back({k * 1e-3, "slip", "f", ""});
  events.push_back({5.0004, "impact", "ground", ""});
  const EventMarks m = GnuplotEventMarks(events, 0, 10);
  EXPECT_EQ(Count(m.arrows, "set arrow"), 200u);
  EXPECT_EQ(Count(m.arrows, "set arrow from first 5.0004, graph 0"), 1u);
  EXPECT_EQ(Count(m.arrows, "lc rgb \"#b2182b\""), 1u);
  EXPECT_THAT(m.arrows, HasSubstr("# 10001 events on [0, 10], thinned: one line for each of 200 equal bins that holds any"));
  EXPECT_THAT(m.keys, HasSubstr("title 'impact (1, thinned)'"));
  EXPECT_THAT(m.keys, HasSubstr("title 'slip (10000, thinned)'"));
  // Bins without events get no line: events in the first half only give at most 100.
  events.resize(5000);
  EXPECT_LE(Count(GnuplotEventMarks(events, 0, 10).arrows, "set arrow"), 100u);
}

TEST(PlotEventsTest, FileTextReachesTheScriptOnlyAsComments) {
  const std::vector<PlotEvent> events = {{1, "impact", "a\nsystem \"touch x\"\n!touch y `touch z` @m\\", "<script>"}};
  const EventMarks m = GnuplotEventMarks(events, 0, 2);
  EXPECT_EQ(m.arrows.find('`'), std::string::npos);
  std::istringstream in(m.arrows);
  int comments = 0;
  for (std::string line; std::getline(in, line);) {
    const size_t first = line.find_first_not_of(' ');
    ASSERT_NE(first, std::string::npos);
    EXPECT_TRUE(line[first] == '#' || line.compare(first, 9, "set arrow") == 0) << line;
    EXPECT_NE(line.back(), '\\') << "a comment that continues onto the next line: " << line;
    comments += line[first] == '#';
  }
  EXPECT_EQ(comments, 2);
  EXPECT_EQ(m.arrows.find("<script>"), std::string::npos);  // the description is not in the script
}

}  // namespace
}  // namespace multibond
