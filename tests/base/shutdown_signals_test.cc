#include "base/shutdown_signals.h"

#include <pthread.h>
#include <signal.h>

#include <chrono>

#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

using std::chrono::milliseconds;

// Restores the thread's signal mask, so that the test leaves the process as it found it.
class ShutdownSignalsTest : public ::testing::Test {
 protected:
  void SetUp() override { pthread_sigmask(SIG_SETMASK, nullptr, &saved_); }
  void TearDown() override { pthread_sigmask(SIG_SETMASK, &saved_, nullptr); }
  sigset_t saved_;
};

TEST_F(ShutdownSignalsTest, BlockedSignalsWaitForTheWaiter) {
  BlockShutdownSignals();
  sigset_t now;
  pthread_sigmask(SIG_SETMASK, nullptr, &now);
  EXPECT_EQ(sigismember(&now, SIGINT), 1);
  EXPECT_EQ(sigismember(&now, SIGTERM), 1);

  EXPECT_EQ(WaitForShutdownSignal(milliseconds(20)), 0) << "nothing pending: times out";
  ASSERT_EQ(pthread_kill(pthread_self(), SIGTERM), 0);  // pending, not delivered: blocked
  EXPECT_EQ(WaitForShutdownSignal(milliseconds(1000)), SIGTERM);
  ASSERT_EQ(pthread_kill(pthread_self(), SIGINT), 0);
  EXPECT_EQ(WaitForShutdownSignal(), SIGINT);
  EXPECT_EQ(WaitForShutdownSignal(milliseconds(0)), 0) << "each signal is taken once";
}

}  // namespace
}  // namespace meshsmooth
