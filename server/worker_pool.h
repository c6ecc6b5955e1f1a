// A fixed pool of worker threads with a bounded queue: a task that does not fit is refused at
// once (the caller answers RESOURCE_EXHAUSTED), never left to wait without bound.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace meshsmooth::server {

class WorkerPool {
 public:
  WorkerPool(int workers, int queue_depth);
  ~WorkerPool();  // Stop()
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Queues `task`; returns the number of tasks waiting ahead of it (0 when a worker is idle),
  // or nullopt when the queue is full or the pool is stopping.
  std::optional<int> TrySubmit(std::function<void()> task);

  // Refuses new tasks, drops the queued ones (their cancellation is the owner's business),
  // and joins the workers after their current task.
  void Stop();

  // Tasks waiting for a worker now.
  int queued();

 private:
  void Loop();

  const int queue_depth_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  int idle_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace meshsmooth::server
