// The messages between ranks: a result packed and unpacked to the same bits; the environment
// says whether mpirun started the process.

#include "multibond/sweep/mpi_backend.h"

#include <cmath>
#include <cstdlib>
#include <limits>

#include <gtest/gtest.h>

namespace multibond::sweep {
namespace {

TEST(MpiBackend, AResultCrossesBetweenRanksUnchanged) {
  const RunResult r{123456789012L, false, "solver failure at t = 0.5: CV_CONV_FAILURE, \"x\"",
                    {0.1, -0.0, std::numeric_limits<double>::quiet_NaN(), 1e-310}};
  const RunResult back = UnpackResult(PackResult(r));
  EXPECT_EQ(back.run, r.run);
  EXPECT_FALSE(back.ok);
  EXPECT_EQ(back.reason, r.reason);
  ASSERT_EQ(back.values.size(), 4u);
  EXPECT_EQ(back.values[0], 0.1);
  EXPECT_TRUE(std::signbit(back.values[1]));
  EXPECT_TRUE(std::isnan(back.values[2]));
  EXPECT_EQ(back.values[3], 1e-310);
  EXPECT_THROW(UnpackResult(PackResult(r).substr(0, 10)), std::runtime_error);
}

TEST(MpiBackend, OnlyMpirunsEnvironmentStartsMpi) {
  unsetenv("OMPI_COMM_WORLD_SIZE");
  unsetenv("PMI_SIZE");
  unsetenv("OMPI_COMM_WORLD_RANK");
  unsetenv("PMI_RANK");
  EXPECT_FALSE(LaunchedByMpirun());
  EXPECT_EQ(EnvironmentRank(), 0);
  setenv("OMPI_COMM_WORLD_SIZE", "4", 1);
  setenv("OMPI_COMM_WORLD_RANK", "3", 1);
  EXPECT_TRUE(LaunchedByMpirun());
  EXPECT_EQ(EnvironmentRank(), 3);
}

}  // namespace
}  // namespace multibond::sweep
