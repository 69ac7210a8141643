// Running external programs (core/process.cc): a stop asked for while a child runs ends the
// child and its process group, and the wait throws Interrupted.

#include <signal.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/core/interrupt.h"
#include "multibond/core/process.h"
#include "support/alive.h"
#include "support/temp_dir.h"

namespace multibond {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using testing::Alive;

/// Sets the stop flag after `ms` milliseconds, from another thread (as a signal handler would).
class StopLater {
 public:
  explicit StopLater(int ms) : thread_([ms] {
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    StopFlag().store(true);
  }) {}
  ~StopLater() {
    thread_.join();
    ResetStop();
  }

 private:
  std::thread thread_;
};

class ProcessTest : public ::testing::Test {
 protected:
  void SetUp() override { ResetStop(); }
  void TearDown() override { ResetStop(); }
  testing::TempDir dir_{"multibond-process"};
};

TEST_F(ProcessTest, RunsAProgramAndReportsItsFailure) {
  EXPECT_EQ(RunProcess({"true"}, "", (dir_.path() / "log").string()), "");
  EXPECT_THAT(RunProcess({"sh", "-c", "echo oops >&2; exit 3"}, "", (dir_.path() / "log").string()),
              ::testing::AllOf(::testing::HasSubstr("exit status 3"), ::testing::HasSubstr("oops")));
}

TEST_F(ProcessTest, TheChildLeadsItsOwnProcessGroup) {
  std::string error;
  const pid_t pid = StartProcess({"sleep", "5"}, "", (dir_.path() / "log").string(), &error);
  ASSERT_GT(pid, 0) << error;
  EXPECT_EQ(getpgid(pid), pid);
  EXPECT_NE(getpgid(pid), getpgrp());
  EndProcess(pid);
  EXPECT_FALSE(Alive(pid));
}

// Before: the wait blocked in waitpid until `sleep 30` ended, and then reported success.
TEST_F(ProcessTest, AStopEndsTheChildAndThrowsInterrupted) {
  std::string error;
  const pid_t pid = StartProcess({"sleep", "30"}, "", (dir_.path() / "log").string(), &error);
  ASSERT_GT(pid, 0) << error;
  const auto start = Clock::now();
  {
    StopLater stop(200);
    EXPECT_THROW(WaitProcess(pid, "sleep"), Interrupted);
  }
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(2));
  EXPECT_FALSE(Alive(pid));
}

TEST_F(ProcessTest, RunProcessThrowsInterruptedWithinTwoSeconds) {
  const auto start = Clock::now();
  StopLater stop(200);
  try {
    RunProcess({"sleep", "30"}, "", (dir_.path() / "log").string());
    ADD_FAILURE() << "RunProcess returned although a stop was asked for";
  } catch (const Interrupted& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("running 'sleep'"));
    EXPECT_EQ(e.ExitCode(), 128 + SIGINT);  // no signal recorded: a stop from the API counts as SIGINT
  }
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(2));
}

// A compiler driver runs cc1plus and as as its own children: they go with it.
TEST_F(ProcessTest, AStopEndsTheChildsChildrenToo) {
  const fs::path pid_file = dir_.path() / "grandchild.pid";
  std::string error;
  const pid_t pid = StartProcess({"sh", "-c", "sleep 30 & echo $! > \"$0\"; wait", pid_file.string()}, "",
                                 (dir_.path() / "log").string(), &error);
  ASSERT_GT(pid, 0) << error;
  pid_t grandchild = 0;
  for (int i = 0; i < 200 && grandchild == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::ifstream(pid_file) >> grandchild;
  }
  ASSERT_GT(grandchild, 0);
  ASSERT_TRUE(Alive(grandchild));
  {
    StopLater stop(100);
    EXPECT_THROW(WaitProcess(pid, "sh"), Interrupted);
  }
  for (int i = 0; i < 100 && Alive(grandchild); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(Alive(grandchild));
  EXPECT_FALSE(Alive(pid));
}

TEST_F(ProcessTest, NothingStartsOnceAStopWasAskedFor) {
  StopFlag().store(true);
  const fs::path marker = dir_.path() / "ran";
  EXPECT_THROW(RunProcess({"touch", marker.string()}, "", (dir_.path() / "log").string()), Interrupted);
  EXPECT_FALSE(fs::exists(marker));
}

}  // namespace
}  // namespace multibond
