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
  // or nullopt when the queue is full or the pool is stopping. Once `abandoned` returns true
  // (its owner gave the task up while it waited), the task no longer holds a place in the
  // queue; a worker still runs it, and it must then return at once.
  std::optional<int> TrySubmit(std::function<void()> task, std::function<bool()> abandoned = nullptr);

  // Refuses new tasks, drops the queued ones (their cancellation is the owner's business),
  // and joins the workers after their current task.
  void Stop();

  // Tasks waiting for a worker now (abandoned ones not counted).
  int queued();
  // Tasks a worker runs now.
  int running();
  int workers() const { return workers_; }

 private:
  struct Task {
    std::function<void()> run;
    std::function<bool()> abandoned;  // may be empty
  };
  void Loop();
  // Queued tasks not abandoned; mu_ held.
  int WaitingLocked() const;

  const int queue_depth_;
  const int workers_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Task> queue_;
  int idle_ = 0;
  int running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace meshsmooth::server
