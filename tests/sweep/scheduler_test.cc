// The queue hands out each run once; threads drain it; the progress line says the time left.

#include "multibond/sweep/scheduler.h"

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>

#include <gtest/gtest.h>

namespace multibond::sweep {
namespace {

TEST(Scheduler, EveryRunOnceOverThreads) {
  std::vector<long> pending;
  for (long i = 0; i < 1000; i += 2) pending.push_back(i);
  WorkQueue queue(pending);
  std::mutex m;
  std::multiset<long> seen;
  std::set<int> threads;
  RunThreads(queue, 3, [&](long run, int thread) {
    std::lock_guard<std::mutex> lock(m);
    seen.insert(run);
    threads.insert(thread);
  }, nullptr);
  EXPECT_EQ(seen.size(), 500u);
  EXPECT_EQ(std::set<long>(seen.begin(), seen.end()).size(), 500u);  // none twice
  EXPECT_EQ(*seen.rbegin(), 998);
  EXPECT_EQ(queue.Next(), -1);
}

TEST(Scheduler, AStopEndsTheQueueAndAnErrorIsRethrown) {
  std::atomic<bool> stop{true};
  WorkQueue stopped({1, 2, 3});
  EXPECT_EQ(stopped.Next(&stop), -1);
  WorkQueue queue({1, 2, 3, 4, 5, 6});
  EXPECT_THROW(RunThreads(queue, 2, [&](long run, int) {
    if (run == 2) throw std::runtime_error("disk full");
  }, nullptr), std::runtime_error);
}

TEST(Scheduler, TheProgressLine) {
  EXPECT_EQ(ProgressBar::Line(45, 100, 2, 9.0, 45), "[#############.................] 45/100 runs (2 failed), 11 s left");
  // Resumed runs count as done but not in the rate: 10 run here in 5 s, 50 to go.
  EXPECT_EQ(ProgressBar::Line(50, 100, 0, 5.0, 10), "[###############...............] 50/100 runs, 25 s left");
  EXPECT_EQ(ProgressBar::Line(100, 100, 0, 5.0, 100), "[##############################] 100/100 runs");
  EXPECT_EQ(ProgressBar::Line(0, 1000, 0, 0.0, 0), "[..............................] 0/1000 runs");
  EXPECT_EQ(ProgressBar::Line(10, 1000, 0, 60.0, 10), "[..............................] 10/1000 runs, 99 min left");
}

}  // namespace
}  // namespace multibond::sweep
