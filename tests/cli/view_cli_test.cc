// multibond view: the results page written when needed (and only then), with the model's scene
// when --model is given, opened with xdg-open or its path printed.

#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using multibond::testing::ReadFile;

const std::string kExamples = std::string(MULTIBOND_SOURCE_DIR) + "/examples/";

TEST(ViewCliTest, WritesThePageWhenNeededAndSaysWhereItIs) {
  const multibond::testing::TempDir t("multibond-view-test");
  const fs::path dir = t.path() / "msd";
  ASSERT_EQ(multibond::testing::RunCli({"run", kExamples + "mass_spring_damper.yaml", "-o", dir.string(), "-q", "--t-end", "0.2"}).code, 0);
  const auto first = multibond::testing::RunCli({"view", dir.string(), "--no-open"});
  ASSERT_EQ(first.code, 0) << first.out;
  const std::string page = fs::canonical(dir / "index.html").string();
  EXPECT_THAT(first.out, HasSubstr("wrote " + page));
  EXPECT_THAT(first.out, HasSubstr("open file://" + page + " in a browser"));
  const std::string html = ReadFile(page);
  // The interactive part, or (multibond built without node) the note that says it is missing.
  const bool interactive = html.find("<script src=\"multibond-page.js\"></script>") != std::string::npos;
  EXPECT_NE(interactive, html.find("is not installed") != std::string::npos);
  EXPECT_EQ(interactive, fs::is_regular_file(dir / "multibond-page.js"));
  EXPECT_NE(html.find("{\"name\":\"spring.q\",\"unit\":\"m\"}"), std::string::npos);
  EXPECT_NE(html.find("\"scene\":null"), std::string::npos);

  // Up to date: not written again.
  const auto when = fs::last_write_time(page);
  const auto again = multibond::testing::RunCli({"view", dir.string(), "--no-open"});
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_THAT(again.out, Not(HasSubstr("wrote")));
  EXPECT_EQ(fs::last_write_time(page), when);

  // No xdg-open on PATH: the path is printed, and view succeeds.
  const std::string path = getenv("PATH") ? getenv("PATH") : "";
  setenv("PATH", t.path().c_str(), 1);
  const auto no_browser = multibond::testing::RunCli({"view", dir.string()});
  setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(no_browser.code, 0) << no_browser.out;
  EXPECT_THAT(no_browser.out, HasSubstr("open file://" + page + " in a browser"));
}

TEST(ViewCliTest, TheModelGivesTheSceneAndTheGraph) {
  const multibond::testing::TempDir t("multibond-view-test");
  const fs::path dir = t.path() / "differential";
  ASSERT_EQ(multibond::testing::RunCli({"run", kExamples + "differential.yaml", "-o", dir.string(), "-q", "--t-end", "0.05"}, 120).code, 0);
  const auto view = multibond::testing::RunCli({"view", dir.string(), "--no-open", "--model", kExamples + "differential.yaml"}, 120);
  ASSERT_EQ(view.code, 0) << view.out;
  const std::string html = ReadFile(dir / "index.html");
  // (found, not matched: the page is too large for a failure message)
  for (const char* part : {"\"scene\":{\"bodies\":[{\"name\":\"H\"", "{\"at\":[0.0,0.05,0.0],\"body\":\"P1\",\"name\":\"Q_P1\"}",
                           "\"graph\":{\"bb\":", "\"element\":\"drive.source\""})
    EXPECT_NE(html.find(part), std::string::npos) << part;
}

TEST(ViewCliTest, AFolderWithoutResultsIsAnError) {
  const multibond::testing::TempDir t("multibond-view-test");
  const auto view = multibond::testing::RunCli({"view", t.path().string(), "--no-open"});
  EXPECT_EQ(view.code, 74) << view.out;
  EXPECT_THAT(view.out, HasSubstr("results.csv"));
  EXPECT_FALSE(fs::exists(t.path() / "index.html"));
}

}  // namespace
