#include "quadhand/core/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

namespace quadhand::core {
namespace {

TEST(WorkerPoolTest, RunsEveryWorkerOncePerRunAndWaitsForAll) {
  for (int workers : {1, 2, 3, 8}) {
    WorkerPool pool(workers);
    ASSERT_EQ(pool.size(), workers);
    std::vector<int> runs(workers, 0);  // each worker writes only its own entry
    std::atomic<int> finished{0};
    for (int round = 0; round < 2000; ++round) {
      pool.Run([&](int worker) {
        ++runs[worker];
        finished.fetch_add(1);
      });
      // Run() has returned: every worker's part is done.
      ASSERT_EQ(finished.load(), (round + 1) * workers) << workers;
    }
    for (int count : runs) EXPECT_EQ(count, 2000);
  }
}

TEST(WorkerPoolTest, SleepingWorkersWakeForTheNextRun) {
  WorkerPool pool(2);
  std::atomic<int> finished{0};
  for (int round = 0; round < 3; ++round) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // past the polling
    pool.Run([&](int) { finished.fetch_add(1); });
  }
  EXPECT_EQ(finished.load(), 6);
}

TEST(WorkerPoolTest, CountsWorkers) {
  EXPECT_EQ(WorkerCount(3), 3);
  EXPECT_GE(WorkerCount(0), 1);
  EXPECT_EQ(WorkerCount(0, 1), 1);
  EXPECT_EQ(WorkerCount(500, 4), 4);
}

}  // namespace
}  // namespace quadhand::core
