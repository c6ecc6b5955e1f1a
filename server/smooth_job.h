// One smoothing job, free of gRPC: decode the upload, validate, smooth, encode, and report
// each step to a sink (the RPC's reactor). Runs on a worker of the pool.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/status.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/convert.h"
#include "server/options.h"

namespace meshsmooth::server {

// Receives a job's events, in this order: OnAccepted, OnProgress*, then OnResult or OnError
// (OnError may also come first). Called from the worker thread.
class JobSink {
 public:
  virtual ~JobSink() = default;
  virtual void OnAccepted(const v1::Accepted& accepted) = 0;
  virtual void OnProgress(const v1::Progress& progress) = 0;
  virtual void OnResult(std::string draco_bytes, const v1::Summary& summary) = 0;
  virtual void OnError(const absl::Status& status) = 0;
};

using Clock = std::chrono::steady_clock;

class SmoothJob {
 public:
  SmoothJob(std::string id, JobParams params, std::string upload, Clock::time_point received,
            const ServerOptions& options, JobSink* sink);

  const std::string& id() const { return id_; }
  void set_queue_position(int position) { queue_position_ = position; }
  void set_submitted(Clock::time_point t) { submitted_ = t; }

  // Runs the whole job; returns when it is done, failed or cancelled.
  void Run();

  // Stops the job within one iteration and drops the sink: no event is delivered after this
  // returns. Frees the upload if the job has not started.
  void Detach();

 private:
  template <typename Fn>
  void Emit(Fn&& fn);
  void Log(const std::string& status, int64_t vertices, int iterations, double decode, double queue,
           double smooth, double encode) const;

  const std::string id_;
  const JobParams params_;
  std::string upload_;
  const Clock::time_point received_;
  Clock::time_point submitted_;
  std::atomic<int> queue_position_{0};
  const ServerOptions& options_;
  std::atomic<bool> cancel_{false};
  std::mutex mu_;        // guards sink_ and upload_
  JobSink* sink_;
};

}  // namespace meshsmooth::server
