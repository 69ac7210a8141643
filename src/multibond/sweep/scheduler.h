#pragma once
/// \file
/// Local parallelism: a queue that hands out the pending runs one at a time (dynamic load
/// balancing: a thread or rank that finishes early takes the next run), worker threads that
/// drain it, and a progress line with the estimated time left.

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace multibond::sweep {

/// The runs still to do, each handed out once, in order. Thread-safe.
class WorkQueue {
 public:
  explicit WorkQueue(std::vector<long> pending) : pending_(std::move(pending)) {}
  /// The next run, or -1 when none is left or `stop` is set.
  long Next(const std::atomic<bool>* stop = nullptr) {
    if (stop && stop->load(std::memory_order_relaxed)) return -1;
    const size_t i = next_.fetch_add(1, std::memory_order_relaxed);
    return i < pending_.size() ? pending_[i] : -1;
  }
  size_t size() const { return pending_.size(); }

 private:
  std::vector<long> pending_;
  std::atomic<size_t> next_{0};
};

/// Runs `work(run, thread)` for the queue's runs on `threads` threads (the calling thread waits).
/// An exception from `work` stops the others from taking runs and is rethrown here.
void RunThreads(WorkQueue& queue, int threads, const std::function<void(long run, int thread)>& work, const std::atomic<bool>* stop);

/// "[#####.....] 45/100 runs (2 failed), 12 s left" on a terminal, redrawn at most 4 times a
/// second; nothing when `enabled` is false. Thread-safe.
class ProgressBar {
 public:
  ProgressBar(long total, long already_done, bool enabled);
  void Done(bool ok);
  /// Ends the line.
  void Finish();
  static std::string Line(long done, long total, long failed, double elapsed, long done_here);

 private:
  std::mutex m_;
  long total_, done_, failed_ = 0, done_here_ = 0;
  bool enabled_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace multibond::sweep
