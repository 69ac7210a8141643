// The hostile corpus: inputs an attacker or a hurried user could give multibond. Every file in
// tests/models/hostile/ opens with header lines that say what the command line must do:
//   # hostile: what the file attacks
//   # args: run {model} -o {out} -q --jit off   (optional; this is the default; {model} is the
//           file, {out} a fresh folder that does not exist yet, {dir} its parent)
//   # exit: the expected exit code
//   # expect: a text the output must hold (repeatable)
//   # absent: a text the output must not hold (repeatable)
//   # jit: same   (optional) the run succeeds, and again with --jit on instead of --jit off: from
//           generated code, with results.csv the same to the byte
//   # within: S   (optional) the command ends within S seconds, not the 60 of a hang (a run that
//           must not wait for its generated code to compile)
// Whatever the case, the command must not crash (no signal), hang (60 s), end in an uncaught
// exception, create /tmp/multibond_pwned (the files' attempts at a shell all touch it), or, when
// it fails, leave results.csv or run.json behind. Inputs that cannot be kept
// as files (devices, 50 MB) are made by the tests at the end.

#include <sys/stat.h>

#include <algorithm>
#include <functional>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/cli_runner.h"
#include "support/corpus_header.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::CliResult;
using testing::RunCli;
using testing::TempDir;

constexpr const char* kCorpus = MULTIBOND_SOURCE_DIR "/tests/models/hostile";

struct Case {
  std::string hostile, args = "run {model} -o {out} -q --jit off";
  int exit = -1;
  std::vector<std::string> expect, absent;
  bool jit_same = false;
  double within = 60;
};

Case ReadCase(const fs::path& file) {
  Case c;
  for (const auto& [key, value] : testing::ReadCorpusHeader(file)) {
    if (key == "hostile") c.hostile = value;
    else if (key == "args") c.args = value;
    else if (key == "exit") c.exit = std::stoi(value);
    else if (key == "expect") c.expect.push_back(value);
    else if (key == "absent") c.absent.push_back(value);
    else if (key == "jit") c.jit_same = value == "same";
    else if (key == "within") c.within = std::stod(value);
  }
  return c;
}

std::vector<fs::path> CorpusFiles() {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(kCorpus, ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
  return s;
}

/// What every hostile input must not do, whatever the command answers.
void ExpectContained(const CliResult& r, const fs::path& out) {
  EXPECT_FALSE(r.timed_out) << "hung: killed after 60 s\n" << r.out;
  EXPECT_EQ(r.signal, 0) << "ended by signal " << r.signal << "\n" << r.out;
  EXPECT_THAT(r.out, Not(HasSubstr("terminate called")));
  EXPECT_THAT(r.out, Not(HasSubstr("what():")));
  EXPECT_THAT(r.out, Not(HasSubstr("AddressSanitizer")));
  EXPECT_THAT(r.out, Not(HasSubstr("runtime error:")));  // UBSan
  EXPECT_FALSE(fs::exists("/tmp/multibond_pwned")) << "a shell command of the input ran\n" << r.out;
  if (r.code != 0) {
    EXPECT_FALSE(fs::exists(out / "results.csv")) << "a failed command left results.csv\n" << r.out;
    EXPECT_FALSE(fs::exists(out / "run.json")) << "a failed command left run.json\n" << r.out;
  }
}

TEST(HostileCorpus, HasCases) { EXPECT_GE(CorpusFiles().size(), 10u) << kCorpus; }

class Hostile : public ::testing::TestWithParam<fs::path> {};

TEST_P(Hostile, IsAnsweredAsTheHeaderSays) {
  const fs::path& file = GetParam();
  const Case c = ReadCase(file);
  ASSERT_FALSE(c.hostile.empty()) << file << " has no '# hostile:' line";
  ASSERT_GE(c.exit, 0) << file << " has no '# exit:' line";
  TempDir tmp("multibond-hostile");
  const fs::path out = tmp.path() / "out";
  auto make_args = [&](const std::string& line, const fs::path& folder) {
    std::vector<std::string> args;
    std::istringstream words(line);
    for (std::string w; words >> w;)
      args.push_back(Replace(Replace(Replace(w, "{model}", file.string()), "{out}", folder.string()), "{dir}", tmp.path().string()));
    return args;
  };
  const CliResult r = RunCli(make_args(c.args, out), c.within);
  SCOPED_TRACE(c.hostile);
  EXPECT_FALSE(r.timed_out) << "not ended within " << c.within << " s";
  ExpectContained(r, out);
  EXPECT_EQ(r.code, c.exit) << r.out;
  for (const std::string& e : c.expect) EXPECT_THAT(r.out, HasSubstr(e));
  for (const std::string& a : c.absent) EXPECT_THAT(r.out, Not(HasSubstr(a)));
  if (c.jit_same) {
    ASSERT_EQ(r.code, 0) << "'# jit: same' needs a run that succeeds";
    ASSERT_THAT(c.args, HasSubstr("--jit off"));
    const fs::path out_jit = tmp.path() / "out_jit";
    const CliResult j = RunCli(make_args(Replace(c.args, "--jit off", "--jit on"), out_jit));
    ExpectContained(j, out_jit);
    ASSERT_EQ(j.code, 0) << j.out;
    EXPECT_THAT(testing::ReadFile(out_jit / "run.json"), HasSubstr("\"rhs_engine\": \"generated code"));
    EXPECT_EQ(testing::ReadFile(out / "results.csv"), testing::ReadFile(out_jit / "results.csv"));
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, Hostile, ::testing::ValuesIn(CorpusFiles()), [](const auto& info) {
  std::string name = info.param.stem().string();
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
});

// Models that are not files a person wrote: devices, pipes, folders, and a file of 50 MB.

CliResult RunModel(const std::string& model, const fs::path& out) { return RunCli({"run", model, "-o", out.string(), "-q", "--jit", "off"}, 60); }

TEST(HostileInput, DevicesAndFoldersAreNotModelFiles) {
  TempDir tmp("multibond-hostile");
  const fs::path fifo = tmp.path() / "model.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& model : std::vector<std::string>{"/dev/zero", "/dev/urandom", fifo.string(), tmp.path().string()}) {
    SCOPED_TRACE(model);
    const fs::path out = tmp.path() / "out";
    const CliResult r = RunModel(model, out);
    ExpectContained(r, out);
    EXPECT_EQ(r.code, 74) << r.out;
    EXPECT_THAT(r.out, HasSubstr("error: cannot read the model file: it is a"));
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(HostileInput, AFileLargerThanTheLimitIsRefusedBeforeItIsRead) {
  TempDir tmp("multibond-hostile");
  const fs::path big = tmp.path() / "big.yaml";
  {
    std::ofstream f(big, std::ios::binary);
    const std::string line = "# " + std::string(1022, 'x') + "\n";
    for (int i = 0; i < 50 * 1024; ++i) f << line;  // 50 MiB
  }
  const fs::path out = tmp.path() / "out";
  CliResult r = RunModel(big.string(), out);
  ExpectContained(r, out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("--limit file-size="));
  // The limit can be lowered too: a small model over a small limit is refused the same way.
  r = RunCli({"check", MULTIBOND_SOURCE_DIR "/examples/mass_spring_damper.yaml", "--limit", "file-size=100"});
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("--limit file-size="));
}

// Results folders are inputs too: `plot DIR` reads only DIR's own regular files, writes only
// inside DIR, and says what is wrong with exit 74.

TEST(HostileResultsFolder, LinksFifosAndJunkAreRefusedAndNothingIsWrittenOutside) {
  TempDir tmp("multibond-hostile"), elsewhere("multibond-elsewhere");
  const fs::path good = tmp.path() / "good";
  ASSERT_EQ(RunCli({"run", MULTIBOND_SOURCE_DIR "/examples/mass_spring_damper.yaml", "-o", good.string(), "-q", "--t-end", "0.1"}).code, 0);
  struct Folder {
    std::string what, expect;
    std::function<void(const fs::path&)> make;
  };
  const std::vector<Folder> folders = {
      {"results.csv is a link to a system file", "is a symbolic link",
       [](const fs::path& d) { fs::create_symlink("/etc/passwd", d / "results.csv"); }},
      {"run.json is a link to a system file", "is a symbolic link",
       [&](const fs::path& d) {
         fs::copy_file(good / "results.csv", d / "results.csv");
         fs::create_symlink("/etc/hostname", d / "run.json");
       }},
      {"run.json is a FIFO (no hang)", "is not a regular file",
       [&](const fs::path& d) {
         fs::copy_file(good / "results.csv", d / "results.csv");
         ASSERT_EQ(mkfifo((d / "run.json").c_str(), 0600), 0);
       }},
      {"figures/ is a link out of the folder", "is a symbolic link",
       [&](const fs::path& d) {
         fs::copy_file(good / "results.csv", d / "results.csv");
         fs::create_directory_symlink(elsewhere.path(), d / "figures");
       }},
      {"results.csv is random bytes", "results.csv",
       [](const fs::path& d) {
         std::ifstream random("/dev/urandom", std::ios::binary);
         std::string bytes(100000, '\0');
         random.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
         std::ofstream(d / "results.csv", std::ios::binary) << bytes;
       }},
      {"results.csv is empty", "empty file", [](const fs::path& d) { std::ofstream(d / "results.csv"); }},
  };
  int k = 0;
  for (const Folder& f : folders) {
    SCOPED_TRACE(f.what);
    const fs::path dir = tmp.path() / ("case" + std::to_string(++k));
    fs::create_directories(dir);
    f.make(dir);
    const CliResult r = RunCli({"plot", dir.string()}, 30);
    ExpectContained(r, dir / "no-such-output");
    EXPECT_EQ(r.code, 74) << r.out;
    EXPECT_THAT(r.out, HasSubstr(f.expect));
    EXPECT_FALSE(fs::exists(dir / "index.html"));
    EXPECT_TRUE(fs::is_empty(elsewhere.path())) << "plot wrote through a link";
  }
}

}  // namespace
}  // namespace multibond
