// The pieces of meshsmoothd's metrics and JSON log that need no server: the process samples read
// from a made-up /proc, and JSON quoting (server/metrics.h, server/log.h).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "gtest/gtest.h"
#include "server/admission.h"
#include "server/log.h"
#include "server/metrics.h"

namespace meshsmooth::server {
namespace {

namespace fs = std::filesystem;

class FakeProc : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("meshsmooth-proc-" + std::to_string(getpid()));
    fs::create_directories(dir_ / "self" / "fd");
    for (const char* fd : {"0", "1", "2", "3", "4"}) std::ofstream(dir_ / "self" / "fd" / fd).put('x');
    // A command name with a space and a parenthesis: the fields are counted after the last ')'.
    // utime 250, stime 150 ticks; starttime 1000 ticks; vsize 123456789 bytes; rss 1000 pages.
    std::ofstream(dir_ / "self" / "stat") << "4242 (mesh smooth) d) S 1 4242 4242 0 -1 4194560 100 0 0 0 250 150 0 0 "
                                             "20 0 7 0 1000 123456789 1000 18446744073709551615";
    std::ofstream(dir_ / "self" / "limits")
        << "Limit                     Soft Limit           Hard Limit           Units\n"
           "Max open files            1024                 1048576              files\n";
    std::ofstream(dir_ / "stat") << "cpu  1 2 3 4\nbtime 1700000000\nprocesses 99\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(FakeProc, ReadsCpuMemoryStartAndDescriptorsAsPrometheusNamesThem) {
  const std::optional<ProcessSamples> s = ReadProcessSamples((dir_ / "self").string(), (dir_ / "stat").string());
  ASSERT_TRUE(s.has_value());
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  EXPECT_DOUBLE_EQ(s->cpu_seconds, 400 / ticks);
  EXPECT_DOUBLE_EQ(s->start_time_seconds, 1700000000 + 1000 / ticks);
  EXPECT_DOUBLE_EQ(s->virtual_memory_bytes, 123456789);
  EXPECT_DOUBLE_EQ(s->resident_memory_bytes, 1000.0 * static_cast<double>(sysconf(_SC_PAGESIZE)));
  EXPECT_DOUBLE_EQ(s->max_fds, 1024);
  EXPECT_DOUBLE_EQ(s->open_fds, 4);  // five entries, less the one that lists them
}

TEST_F(FakeProc, ATruncatedStatIsNoSample) {
  std::ofstream(dir_ / "self" / "stat") << "4242 (meshsmoothd) S 1 4242";
  EXPECT_FALSE(ReadProcessSamples((dir_ / "self").string(), (dir_ / "stat").string()).has_value());
  EXPECT_FALSE(ReadProcessSamples((dir_ / "missing").string(), (dir_ / "stat").string()).has_value());
}

TEST(ProcessSamples, ThisProcessHasMemoryAndDescriptors) {
  const std::optional<ProcessSamples> s = ReadProcessSamples();
  ASSERT_TRUE(s.has_value());
  EXPECT_GT(s->resident_memory_bytes, 1 << 20);
  EXPECT_GE(s->open_fds, 3);
}

TEST(RefusalNames, EveryReasonHasItsOwnLabel) {
  std::set<std::string> names;
  for (int i = 0; i < kRefusalCount; ++i) names.insert(std::string(RefusalName(static_cast<Refusal>(i))));
  EXPECT_EQ(names.size(), static_cast<size_t>(kRefusalCount));
  EXPECT_EQ(names.count("unknown"), 0u);
  EXPECT_EQ(RefusalName(Refusal::kQueueFull), "queue_full");
}

TEST(RefusalNames, OnlyTheServersCapacityIsTransient) {
  std::set<std::string> transient;
  for (int i = 0; i < kRefusalCount; ++i) {
    if (IsTransient(static_cast<Refusal>(i))) transient.insert(std::string(RefusalName(static_cast<Refusal>(i))));
  }
  EXPECT_EQ(transient, (std::set<std::string>{"queue_full", "queue_wait", "memory_budget", "too_many_calls"}));
}

// A refused call's log entry: method, reason, status, peer, the job id once known, the error.
TEST(RefusalLog, TextAndJsonNameWhatAnOperatorFiltersOn) {
  const grpc::Status status(grpc::StatusCode::RESOURCE_EXHAUSTED, "the job queue is full (0 jobs waiting); \"x\"");
  const RefusedCall call{"Smooth", "queue_full", status, "ipv4:127.0.0.1:4242", "scan-7"};
  EXPECT_EQ(RefusalLogLine(call),
            "meshsmoothd refused method=Smooth reason=queue_full status=RESOURCE_EXHAUSTED peer=ipv4:127.0.0.1:4242 "
            "job=scan-7 error=\"the job queue is full (0 jobs waiting); \\\"x\\\"\"");
  const std::string json = RefusalLogJson(call);
  for (const char* field :
       {"\"level\":\"warning\"", "\"event\":\"refused\"", "\"method\":\"Smooth\"", "\"reason\":\"queue_full\"",
        "\"status\":\"RESOURCE_EXHAUSTED\"", "\"peer\":\"ipv4:127.0.0.1:4242\"", "\"job_id\":\"scan-7\"",
        "\"error\":\"the job queue is full"}) {
    EXPECT_NE(json.find(field), std::string::npos) << field << " in " << json;
  }
  const grpc::Status unauthenticated(grpc::StatusCode::UNAUTHENTICATED, "missing or wrong bearer token");
  const RefusedCall guess{"ListFlows", "unauthenticated", unauthenticated, "ipv4:10.0.0.9:5555", ""};
  EXPECT_EQ(
      RefusalLogLine(guess),
      "meshsmoothd refused method=ListFlows reason=unauthenticated status=UNAUTHENTICATED peer=ipv4:10.0.0.9:5555 "
      "error=\"missing or wrong bearer token\"");
  EXPECT_EQ(RefusalLogJson(guess).find("job_id"), std::string::npos);
}

TEST(JsonQuote, EscapesQuotesControlsAndBytesThatAreNotUtf8) {
  EXPECT_EQ(JsonQuote("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(JsonQuote("l1\nl2\t"), "\"l1\\nl2\\u0009\"");
  EXPECT_EQ(JsonQuote("caf\xc3\xa9"), "\"caf\xc3\xa9\"");  // UTF-8 kept
  EXPECT_EQ(JsonQuote("bad\xff"
                      "end"),
            "\"bad\\ufffdend\"");                     // a stray byte replaced
  EXPECT_EQ(JsonQuote("cut\xc3"), "\"cut\\ufffd\"");  // a sequence cut short
}

TEST(JsonLine, NumbersThatAreNotFiniteAreNull) {
  const std::string line = JsonLine("info", "job").Num("x", 1.0 / 0.0).Int("n", -3).str();
  EXPECT_NE(line.find("\"x\":null"), std::string::npos) << line;
  EXPECT_NE(line.find("\"n\":-3"), std::string::npos) << line;
  EXPECT_EQ(line.rfind("{\"time\":\"", 0), 0u) << line;
  EXPECT_EQ(line.back(), '}');
}

}  // namespace
}  // namespace meshsmooth::server
