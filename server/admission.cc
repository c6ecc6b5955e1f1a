#include "server/admission.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <utility>

#include "absl/strings/str_cat.h"

namespace meshsmooth::server {

bool MemoryBudget::TryTake(int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  if (bytes > limit_ - held_) return false;
  held_ += bytes;
  return true;
}

void MemoryBudget::Give(int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  held_ -= bytes;
}

int64_t MemoryBudget::held() const {
  std::lock_guard<std::mutex> lock(mu_);
  return held_;
}

BudgetHold::BudgetHold(BudgetHold&& other) noexcept
    : budget_(std::exchange(other.budget_, nullptr)), bytes_(std::exchange(other.bytes_, 0)) {}

BudgetHold& BudgetHold::operator=(BudgetHold&& other) noexcept {
  if (this != &other) {
    Release();
    budget_ = std::exchange(other.budget_, nullptr);
    bytes_ = std::exchange(other.bytes_, 0);
  }
  return *this;
}

bool BudgetHold::TryGrow(int64_t bytes) {
  if (budget_ == nullptr || !budget_->TryTake(bytes)) return false;
  bytes_ += bytes;
  return true;
}

void BudgetHold::Release() {
  if (budget_ != nullptr && bytes_ > 0) budget_->Give(bytes_);
  bytes_ = 0;
}

absl::Status UploadBuffer::Append(std::string_view chunk) {
  const size_t size = bytes_.size() + chunk.size();
  if (static_cast<int64_t>(size) > max_bytes_) {
    return absl::ResourceExhaustedError(absl::StrCat("the upload exceeds this server's limit of ", max_bytes_, " bytes"));
  }
  const size_t capacity = static_cast<size_t>(hold_.bytes());
  if (size > capacity) {
    const size_t grown = std::min(std::max(size, 2 * capacity), static_cast<size_t>(max_bytes_));
    if (!hold_.TryGrow(static_cast<int64_t>(grown - capacity))) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "this server's memory budget for uploads and queued jobs is full (", budget_->held(), " of ",
          budget_->limit(), " bytes held; --max-buffered-bytes); retry later"));
    }
    std::string bigger;
    bigger.reserve(grown);  // from empty: exactly `grown` (growing in place could double it)
    bigger.append(bytes_);
    bytes_.swap(bigger);
  }
  bytes_.append(chunk);
  return absl::OkStatus();
}

int64_t DefaultBufferedBytes(const std::string& meminfo_path) {
  std::ifstream in(meminfo_path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string key, unit;
    int64_t kib = 0;
    if (fields >> key >> kib >> unit && key == "MemTotal:" && unit == "kB" && kib > 0) return kib * 1024 / 4;
  }
  return int64_t{4} << 30;
}

}  // namespace meshsmooth::server
