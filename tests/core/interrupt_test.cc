// One stop flag for every phase: a stop signal sets it and names itself; the exit code is
// 128 + the signal.

#include "multibond/core/interrupt.h"

#include <csignal>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace multibond {
namespace {

using ::testing::HasSubstr;

class InterruptTest : public ::testing::Test {
 protected:
  void SetUp() override {
    InstallStopHandlers();
    ResetStop();
  }
  void TearDown() override { ResetStop(); }
};

TEST_F(InterruptTest, NoStopNoThrow) {
  EXPECT_FALSE(StopRequested());
  EXPECT_NO_THROW(ThrowIfStopRequested("loading"));
}

TEST_F(InterruptTest, SigtermSetsTheFlagAndGives143) {
  std::raise(SIGTERM);  // handled: the test goes on
  EXPECT_TRUE(StopRequested());
  EXPECT_EQ(StopSignal(), SIGTERM);
  try {
    ThrowIfStopRequested("compiling the generated code");
    ADD_FAILURE() << "no Interrupted";
  } catch (const Interrupted& e) {
    EXPECT_EQ(e.ExitCode(), 143);
    EXPECT_THAT(e.what(), HasSubstr("interrupted by SIGTERM while compiling the generated code"));
  }
}

TEST_F(InterruptTest, TheFirstSignalIsTheOneThatCounts) {
  std::raise(SIGINT);
  std::raise(SIGHUP);
  EXPECT_EQ(StopSignal(), SIGINT);
  EXPECT_EQ(Interrupted("x").ExitCode(), 130);
}

}  // namespace
}  // namespace multibond
