// The job store's claims and leases (server/job_store.h) on its SQLite database: the order of
// claims, the lease a claim takes and loses, a takeover once a lease has run out, what a run
// may still write, and the counts the metrics read. The same logic runs on PostgreSQL
// (tests/python/jobs_postgres_test.py drives replicas on one).
#include "server/job_store.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace meshsmooth::server {
namespace {

constexpr int64_t kSecond = 1'000'000;

class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/meshsmooth-job-store-XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    absl::StatusOr<std::unique_ptr<JobStore>> opened = JobStore::Open(dir_, {/*lease_seconds=*/3.0});
    ASSERT_TRUE(opened.ok()) << opened.status();
    store_ = *std::move(opened);
  }
  void TearDown() override {
    store_.reset();
    std::filesystem::remove_all(dir_);
  }

  // A committed job of `bytes`, created at `create_us`.
  std::string Queue(const std::string& request_id, const std::string& bytes, int64_t create_us) {
    EXPECT_TRUE(store_->StartUpload(request_id, "spec", bytes.size(), Sha256(bytes)).ok());
    EXPECT_TRUE(store_->AppendChunk(request_id, 0, bytes).ok());
    absl::StatusOr<std::string> id = store_->Commit(request_id, NewStoredJobId(), create_us);
    EXPECT_TRUE(id.ok()) << id.status();
    return id.value_or("");
  }

  v1::Job Get(const std::string& id) { return store_->Get(id).value(); }

  std::string dir_;
  std::unique_ptr<JobStore> store_;
};

TEST_F(JobStoreTest, ClaimsTheOldestQueuedJobNotSkippedWithItsInput) {
  const std::string a = Queue("a", "first", 1 * kSecond), b = Queue("b", "second", 2 * kSecond);
  std::optional<ClaimedJob> first = store_->Claim({}, 10 * kSecond);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->job_id, a);
  EXPECT_EQ(first->input.upload, "first");
  EXPECT_FALSE(first->takeover);
  EXPECT_EQ(Get(a).state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(Get(a).attempts(), 1u);
  // `a` runs under a live lease: the next claim takes `b`, then nothing is left.
  std::optional<ClaimedJob> second = store_->Claim({a}, 10 * kSecond);
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->job_id, b);
  EXPECT_FALSE(store_->Claim({a, b}, 10 * kSecond).has_value());
}

TEST_F(JobStoreTest, ALeaseThatRanOutIsTakenOverAndTheOldRunCannotWrite) {
  const std::string a = Queue("a", "mesh", 1 * kSecond);
  ASSERT_TRUE(store_->Claim({}, 10 * kSecond).has_value());
  // Renewed within the lease (3 s): still this store's; nobody may take it before it ends.
  EXPECT_TRUE(store_->RenewLease(a, 12 * kSecond));
  EXPECT_FALSE(store_->Claim({}, 14 * kSecond).has_value());
  // 15 s is the end of the renewed lease; past it the job is there to take, one attempt more.
  std::optional<ClaimedJob> again = store_->Claim({}, 15 * kSecond + 1);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->job_id, a);
  EXPECT_TRUE(again->takeover);
  EXPECT_EQ(Get(a).attempts(), 2u);
  v1::Summary summary;
  ASSERT_TRUE(store_->Succeed(a, "result", summary, 16 * kSecond));
  EXPECT_EQ(Get(a).state(), v1::JOB_STATE_SUCCEEDED);
  // A run that ended keeps its result: no later write or renewal of it counts.
  EXPECT_FALSE(store_->Fail(a, absl::InternalError("late"), 17 * kSecond));
  EXPECT_FALSE(store_->RenewLease(a, 17 * kSecond));
  EXPECT_EQ(store_->ReadResult(a, 0, 1 << 20)->data, "result");
}

TEST_F(JobStoreTest, ACancelledRunLosesItsLeaseAndKeepsNothing) {
  const std::string a = Queue("a", "mesh", 1 * kSecond);
  ASSERT_TRUE(store_->Claim({}, 10 * kSecond).has_value());
  ASSERT_TRUE(store_->Cancel(a, 11 * kSecond).ok());
  EXPECT_FALSE(store_->RenewLease(a, 11 * kSecond));
  v1::Summary summary;
  EXPECT_FALSE(store_->Succeed(a, "result", summary, 12 * kSecond));
  EXPECT_EQ(Get(a).state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(store_->ReadResult(a, 0, 1 << 20).status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(JobStoreTest, ReleaseQueuesTheJobAgainAndUndoesAnAttemptThatNeverRan) {
  const std::string a = Queue("a", "mesh", 1 * kSecond);
  ASSERT_TRUE(store_->Claim({}, 10 * kSecond).has_value());
  store_->Release(a, /*undo_attempt=*/true);
  EXPECT_EQ(Get(a).state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(Get(a).attempts(), 0u);
  ASSERT_TRUE(store_->Claim({}, 11 * kSecond).has_value());
  store_->Release(a, /*undo_attempt=*/false);  // a run cut by a stop counts
  EXPECT_EQ(Get(a).attempts(), 1u);
  std::optional<ClaimedJob> again = store_->Claim({}, 12 * kSecond);
  ASSERT_TRUE(again.has_value());
  EXPECT_FALSE(again->takeover);
  EXPECT_EQ(Get(a).attempts(), 2u);
}

TEST_F(JobStoreTest, CountsByStateAndTheOldestQueuedJob) {
  EXPECT_EQ(store_->Counts().oldest_queued_us, 0);
  const std::string a = Queue("a", "mesh", 5 * kSecond);
  Queue("b", "mesh", 7 * kSecond);
  Queue("c", "mesh", 9 * kSecond);
  ASSERT_TRUE(store_->Claim({}, 10 * kSecond).has_value());  // a
  ASSERT_TRUE(store_->Cancel(a, 11 * kSecond).ok());
  const JobCounts counts = store_->Counts();
  EXPECT_EQ(counts.by_state[v1::JOB_STATE_QUEUED], 2);
  EXPECT_EQ(counts.by_state[v1::JOB_STATE_CANCELLED], 1);
  EXPECT_EQ(counts.by_state[v1::JOB_STATE_RUNNING], 0);
  EXPECT_EQ(counts.oldest_queued_us, 7 * kSecond);
}

TEST_F(JobStoreTest, ARunningJobAtOpenIsQueuedAgainInADirectory) {
  const std::string a = Queue("a", "mesh", 1 * kSecond);
  ASSERT_TRUE(store_->Claim({}, 10 * kSecond).has_value());
  store_.reset();  // as a process that died: its lease is still in the row
  absl::StatusOr<std::unique_ptr<JobStore>> reopened = JobStore::Open(dir_);
  ASSERT_TRUE(reopened.ok()) << reopened.status();
  store_ = *std::move(reopened);
  EXPECT_EQ(store_->requeued_at_open(), 1);
  EXPECT_FALSE(store_->shared());
  EXPECT_EQ(Get(a).state(), v1::JOB_STATE_QUEUED);
  std::optional<ClaimedJob> again = store_->Claim({}, 11 * kSecond);
  ASSERT_TRUE(again.has_value());
  EXPECT_FALSE(again->takeover);
}

TEST(JobStoreOpen, APostgresUriThatCannotConnectIsUnavailableWithoutItsPassword) {
  absl::StatusOr<std::unique_ptr<JobStore>> store =
      JobStore::Open("postgresql://user:hunter2@127.0.0.1:1/db?connect_timeout=2");
  ASSERT_EQ(store.status().code(), absl::StatusCode::kUnavailable) << store.status();
  EXPECT_NE(store.status().message().find("127.0.0.1:1/db"), absl::string_view::npos) << store.status();
  EXPECT_EQ(store.status().message().find("hunter2"), absl::string_view::npos) << store.status();
}

}  // namespace
}  // namespace meshsmooth::server
