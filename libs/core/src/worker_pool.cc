#include "quadhand/core/worker_pool.h"

#include <algorithm>

namespace quadhand::core {
namespace {

// About 20-50 microseconds of polling before sleeping: longer than the gap
// between two evaluations of an optimiser, far shorter than a frame.
constexpr int kSpins = 20000;

inline void Relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

}  // namespace

int WorkerCount(int requested, int limit) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return std::clamp(requested > 0 ? requested : cores, 1, std::max(1, limit));
}

WorkerPool::WorkerPool(int workers)
    // More workers than cores would spin while the one holding the core
    // waits: then they only sleep.
    : spins_(std::max(1, workers) <= std::max(1, static_cast<int>(std::thread::hardware_concurrency())) ? kSpins : 0) {
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
  for (int spin = 0; spin < spins_ && remaining_.load(std::memory_order_acquire) != 0; ++spin) Relax();
  if (remaining_.load(std::memory_order_acquire) != 0) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return remaining_.load(std::memory_order_acquire) == 0; });
  }
  task_ = nullptr;
}

void WorkerPool::Loop(int worker) {
  unsigned long seen = 0;
  for (;;) {
    unsigned long now = generation_.load(std::memory_order_acquire);
    for (int spin = 0; spin < spins_ && now == seen; ++spin) {
      Relax();
      now = generation_.load(std::memory_order_acquire);
    }
    if (now == seen) {
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
