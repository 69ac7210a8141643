// InputLimits and --limit NAME=VALUE (io/limits.h).

#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "multibond/io/limits.h"

namespace multibond {
namespace {

using ::testing::HasSubstr;

TEST(Limits, SetLimitReadsNamesAndSuffixes) {
  InputLimits l;
  SetLimit(l, "file-size=32M");
  SetLimit(l, "yaml-nodes=5k");
  SetLimit(l, "depth=10");
  SetLimit(l, "instances=2G");
  EXPECT_EQ(l.file_bytes, 32'000'000u);
  EXPECT_EQ(l.yaml_nodes, 5'000u);
  EXPECT_EQ(l.depth, 10u);
  EXPECT_EQ(l.instances, 2'000'000'000u);
  EXPECT_EQ(LimitNames().size(), 8u);
}

TEST(Limits, SetLimitRefusesWhatIsNoLimit) {
  InputLimits l;
  try {
    SetLimit(l, "dept=3");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("did you mean 'depth'?"));
  }
  EXPECT_THROW(SetLimit(l, "depth"), std::invalid_argument);
  EXPECT_THROW(SetLimit(l, "depth=0"), std::invalid_argument);
  EXPECT_THROW(SetLimit(l, "depth=-1"), std::invalid_argument);
  EXPECT_THROW(SetLimit(l, "depth=1.5"), std::invalid_argument);
  // 15 digits with a G suffix used to wrap around 2^64 to a small number.
  EXPECT_THROW(SetLimit(l, "file-size=999999999999999G"), std::invalid_argument);
  EXPECT_EQ(l.file_bytes, InputLimits{}.file_bytes);
}

TEST(Limits, HintNamesTheOption) {
  EXPECT_EQ(RaiseLimitHint("depth", 64), "if the input is meant to be this large, raise the limit with --limit depth=N (now 64)");
}

}  // namespace
}  // namespace multibond
