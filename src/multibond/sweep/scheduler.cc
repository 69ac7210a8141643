// Worker threads over a shared queue, and the progress line.

#include "multibond/sweep/scheduler.h"

#include <cstdio>
#include <exception>
#include <thread>

#include <fmt/format.h>

namespace multibond::sweep {

void RunThreads(WorkQueue& queue, int threads, const std::function<void(long, int)>& work, const std::atomic<bool>* stop) {
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto body = [&](int thread) {
    try {
      for (long run; !failed.load() && (run = queue.Next(stop)) >= 0;) work(run, thread);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(body, t);
  body(0);
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

ProgressBar::ProgressBar(long total, long already_done, bool enabled)
    : total_(total), done_(already_done), enabled_(enabled), start_(std::chrono::steady_clock::now()), last_(start_) {}

std::string ProgressBar::Line(long done, long total, long failed, double elapsed, long done_here) {
  constexpr int kWidth = 30;
  const int filled = total > 0 ? static_cast<int>(kWidth * done / total) : kWidth;
  std::string bar(static_cast<size_t>(filled), '#');
  bar.resize(kWidth, '.');
  std::string left = "";
  if (done_here > 0 && done < total) {
    const double s = elapsed / static_cast<double>(done_here) * static_cast<double>(total - done);
    left = s < 120 ? fmt::format(", {:.0f} s left", s) : fmt::format(", {:.0f} min left", s / 60);
  }
  return fmt::format("[{}] {}/{} runs{}{}", bar, done, total, failed ? fmt::format(" ({} failed)", failed) : "", left);
}

void ProgressBar::Done(bool ok) {
  std::lock_guard<std::mutex> lock(m_);
  ++done_;
  ++done_here_;
  if (!ok) ++failed_;
  const auto now = std::chrono::steady_clock::now();
  if (!enabled_ || (now - last_ < std::chrono::milliseconds(250) && done_ < total_)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  std::fprintf(stderr, "\r%s\x1b[K", Line(done_, total_, failed_, elapsed, done_here_).c_str());
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  std::lock_guard<std::mutex> lock(m_);
  if (enabled_) std::fprintf(stderr, "\n");
}

}  // namespace multibond::sweep
