// Memory admission: a server-wide budget for the bytes held by uploads in flight and by jobs
// waiting for a worker. An upload takes its buffer's bytes before it keeps a chunk and is
// refused (RESOURCE_EXHAUSTED) when they do not fit; a job gives them back once its upload is
// decoded and freed. Running jobs' meshes are not counted: the number of workers bounds them.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/status.h"

namespace meshsmooth::server {

class MemoryBudget {
 public:
  explicit MemoryBudget(int64_t limit) : limit_(limit) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // Takes `bytes` when they fit under the limit; false (nothing taken) when they do not.
  bool TryTake(int64_t bytes);
  void Give(int64_t bytes);
  int64_t held() const;
  int64_t limit() const { return limit_; }

 private:
  const int64_t limit_;
  mutable std::mutex mu_;
  int64_t held_ = 0;
};

// Bytes taken from a MemoryBudget by one upload, given back when released or destroyed; it
// moves with the upload from the call to its job.
class BudgetHold {
 public:
  BudgetHold() = default;
  explicit BudgetHold(MemoryBudget* budget) : budget_(budget) {}
  BudgetHold(BudgetHold&& other) noexcept;
  BudgetHold& operator=(BudgetHold&& other) noexcept;
  ~BudgetHold() { Release(); }

  // Takes `bytes` more; false (nothing taken) when the budget has no room for them.
  bool TryGrow(int64_t bytes);
  // Gives everything back.
  void Release();
  int64_t bytes() const { return bytes_; }

 private:
  MemoryBudget* budget_ = nullptr;
  int64_t bytes_ = 0;
};

// One call's upload: its bytes, in a buffer that grows geometrically (appends stay linear) and
// whose capacity is held against the budget.
class UploadBuffer {
 public:
  UploadBuffer(MemoryBudget* budget, int64_t max_bytes) : hold_(budget), budget_(budget), max_bytes_(max_bytes) {}

  // Appends `chunk`. ResourceExhausted, keeping nothing of it, when the upload would pass
  // `max_bytes` or the budget has no room for the buffer it needs.
  absl::Status Append(std::string_view chunk);
  bool empty() const { return bytes_.empty(); }
  // The bytes and their hold, for the job; the buffer is empty afterwards.
  std::string TakeBytes() { return std::exchange(bytes_, std::string()); }
  BudgetHold TakeHold() { return std::move(hold_); }

 private:
  std::string bytes_;
  BudgetHold hold_;  // bytes_'s capacity
  MemoryBudget* budget_;
  int64_t max_bytes_;
};

// The default of --max-buffered-bytes: a quarter of the machine's memory (MemTotal in
// /proc/meminfo), or 4 GiB where that cannot be read. A quarter leaves the rest for the running
// jobs, whose decoded meshes take several times their compressed upload.
int64_t DefaultBufferedBytes(const std::string& meminfo_path = "/proc/meminfo");

}  // namespace meshsmooth::server
