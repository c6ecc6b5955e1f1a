#include "server/worker_pool.h"

#include <algorithm>

namespace meshsmooth::server {

WorkerPool::WorkerPool(int workers, int queue_depth)
    : queue_depth_(std::max(0, queue_depth)), workers_(std::max(1, workers)) {
  threads_.reserve(workers_);
  for (int i = 0; i < workers_; ++i) threads_.emplace_back([this] { Loop(); });
}

WorkerPool::~WorkerPool() { Stop(); }

int WorkerPool::WaitingLocked() const {
  return static_cast<int>(
      std::count_if(queue_.begin(), queue_.end(), [](const Task& t) { return !t.abandoned || !t.abandoned(); }));
}

std::optional<int> WorkerPool::TrySubmit(std::function<void()> task, std::function<bool()> abandoned) {
  std::lock_guard<std::mutex> lock(mu_);
  if (stopping_) return std::nullopt;
  // Tasks that an idle worker will take at once do not count against the queue depth.
  // Tasks no idle worker will take; abandoned ones cost a worker nothing and hold no place.
  const int waiting = WaitingLocked() - idle_;
  if (waiting >= queue_depth_) return std::nullopt;
  queue_.push_back({std::move(task), std::move(abandoned)});
  cv_.notify_one();
  return std::max(0, waiting);
}

int WorkerPool::queued() {
  std::lock_guard<std::mutex> lock(mu_);
  return WaitingLocked();
}

int WorkerPool::running() {
  std::lock_guard<std::mutex> lock(mu_);
  return running_;
}

void WorkerPool::Stop() {
  std::deque<Task> dropped;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
    dropped.swap(queue_);
    cv_.notify_all();
  }
  dropped.clear();  // destroys the tasks (and what they own) outside the lock
  for (std::thread& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
}

void WorkerPool::Loop() {
  for (;;) {
    Task task;
    {
      std::unique_lock<std::mutex> lock(mu_);
      ++idle_;
      cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      --idle_;
      if (stopping_) return;
      task = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
    }
    task.run();  // an abandoned task returns at once (and logs that it was)
    std::lock_guard<std::mutex> lock(mu_);
    --running_;
  }
}

}  // namespace meshsmooth::server
