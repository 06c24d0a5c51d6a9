// A small pool of persistent worker threads for work that is split many
// times a second into short parallel parts (the cost's samples, once per
// evaluation: a few hundred microseconds each). Starting threads per part
// would cost as much as the part; these wait for the next part polling for
// 50 microseconds, then asleep. Results that must not depend on the number of
// workers are the caller's business: split the work into parts that do not
// depend on it (pieces, samples) and reduce them in a fixed order.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace quadhand::core {

// The number of workers `requested` means: itself when positive, else one
// per core (at least 1), and never more than `limit`.
int WorkerCount(int requested, int limit = 256);

class WorkerPool {
 public:
  // `workers` >= 1: the calling thread plus workers - 1 threads.
  explicit WorkerPool(int workers);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int size() const { return static_cast<int>(threads_.size()) + 1; }

  // Runs task(worker) for every worker 0 .. size()-1 (0 on the calling
  // thread) and returns when all have returned. Not re-entrant; one caller
  // at a time.
  void Run(const std::function<void(int)>& task);

 private:
  void Loop(int worker);

  std::chrono::steady_clock::duration spin_{};  // polling before sleeping
  std::vector<std::thread> threads_;
  const std::function<void(int)>* task_ = nullptr;
  std::atomic<unsigned long> generation_{0};
  std::atomic<int> remaining_{0};
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable start_;
  std::condition_variable done_;
};

}  // namespace quadhand::core
