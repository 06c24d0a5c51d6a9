#include "quadhand/core/worker_pool.h"

#include <algorithm>
#include <chrono>

namespace quadhand::core {
namespace {

using Clock = std::chrono::steady_clock;

inline void Relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

// Polling before sleeping: longer than the gap between two evaluations of
// an optimiser, far shorter than an evaluation. A time, not a count of
// pause instructions: one pause takes 10 to 150 cycles depending on the
// processor (20 000, the count this replaced, took 385 us on an AMD EPYC),
// and a thread that polls that long after every part takes a core from
// everything else on a busy computer: with one of two cores busy, the
// solve took 2.7x as long as with 50 us (docs/benchmark.md).
constexpr std::chrono::microseconds kSpinTime{50};

// Polls `done` until it holds or `budget` has passed; true when it holds.
template <typename Done>
bool SpinUntil(Clock::duration budget, Done done) {
  if (budget <= Clock::duration::zero()) return done();
  const Clock::time_point until = Clock::now() + budget;
  for (int i = 1;; ++i) {
    if (done()) return true;
    // A clock read costs about as much as a few pauses.
    if (i % 32 == 0 && Clock::now() >= until) return done();
    Relax();
  }
}

}  // namespace

int WorkerCount(int requested, int limit) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return std::clamp(requested > 0 ? requested : cores, 1, std::max(1, limit));
}

WorkerPool::WorkerPool(int workers)
    // More workers than cores would spin while the one holding the core
    // waits: then they only sleep.
    : spin_(std::max(1, workers) <= std::max(1, static_cast<int>(std::thread::hardware_concurrency()))
                ? std::chrono::duration_cast<Clock::duration>(kSpinTime)
                : Clock::duration::zero()) {
  for (int w = 1; w < std::max(1, workers); ++w) threads_.emplace_back(&WorkerPool::Loop, this, w);
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    ++generation_;
  }
  start_.notify_all();
  for (std::thread& thread : threads_) thread.join();
}

void WorkerPool::Run(const std::function<void(int)>& task) {
  if (threads_.empty()) {
    task(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    task_ = &task;
    remaining_.store(static_cast<int>(threads_.size()), std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_release);
  }
  start_.notify_all();
  task(0);
  if (!SpinUntil(spin_, [this] { return remaining_.load(std::memory_order_acquire) == 0; })) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return remaining_.load(std::memory_order_acquire) == 0; });
  }
  task_ = nullptr;
}

void WorkerPool::Loop(int worker) {
  unsigned long seen = 0;
  for (;;) {
    unsigned long now = seen;
    if (!SpinUntil(spin_, [&] { return (now = generation_.load(std::memory_order_acquire)) != seen; })) {
      std::unique_lock<std::mutex> lock(mutex_);
      start_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
      now = generation_.load(std::memory_order_acquire);
    }
    seen = now;
    if (stop_.load(std::memory_order_acquire)) return;
    (*task_)(worker);
    if (remaining_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      done_.notify_one();
    }
  }
}

}  // namespace quadhand::core
