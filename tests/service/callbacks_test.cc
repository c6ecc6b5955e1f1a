// The completion callback's pieces that need no network: the URL check, the body and the
// signature (server/callbacks.h). tests/python/job_callbacks_test.py drives the deliveries.
#include "server/callbacks.h"

#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace meshsmooth::server {
namespace {

using ::testing::HasSubstr;

TEST(CallbackTest, SignatureIsHmacSha256InLowercaseHex) {
  // RFC 4231, test case 2.
  EXPECT_EQ(CallbackSignature("Jefe", "what do ya want for nothing?"),
            "sha256=5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  EXPECT_NE(CallbackSignature("Jefe", "what do ya want for nothing!"),
            CallbackSignature("Jefe", "what do ya want for nothing?"));
}

TEST(CallbackTest, HttpAndHttpsUrlsWithAHostPass) {
  for (const char* url : {"http://127.0.0.1:8080/hook", "https://hooks.example/x?job=1", "HTTPS://Example.COM"}) {
    EXPECT_TRUE(CheckCallbackUrl(url).ok()) << url << ": " << CheckCallbackUrl(url);
  }
}

TEST(CallbackTest, OtherUrlsAreRefusedNamingTheField) {
  const struct {
    std::string url, why;
  } cases[] = {{"ftp://example.com/x", "http:// or https:// only"},
               {"file:///etc/passwd", "http:// or https:// only"},
               {"gopher://example.com", "http:// or https:// only"},
               {"not a url", "is not a URL"},
               {"example.com/hook", "is not a URL"},
               {"http://", "is not a URL"},
               {"http://exa mple.com/", "is not a URL"},
               {"http://example.com/" + std::string(2100, 'a'), "at most 2048"}};
  for (const auto& c : cases) {
    const absl::Status s = CheckCallbackUrl(c.url);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.url;
    EXPECT_THAT(std::string(s.message()), HasSubstr("callback_url")) << c.url;
    EXPECT_THAT(std::string(s.message()), HasSubstr(c.why)) << c.url << ": " << s;
  }
}

TEST(CallbackTest, BodyIsTheJobWithoutItsSpecInProtoFieldNames) {
  v1::Job job;
  job.set_job_id("0123456789abcdef0123456789abcdef");
  job.set_state(v1::JOB_STATE_FAILED);
  job.mutable_spec()->set_callback_url("http://hooks.example/secret-path");
  job.mutable_error()->set_code(3);
  job.mutable_error()->set_message("strength_attribute 'w': no such attribute");
  job.mutable_end_time()->set_seconds(1'800'000'000);
  const std::string body = CallbackBody(job);
  EXPECT_THAT(body, HasSubstr("\"job_id\":\"0123456789abcdef0123456789abcdef\""));
  EXPECT_THAT(body, HasSubstr("\"state\":\"JOB_STATE_FAILED\""));
  EXPECT_THAT(body, HasSubstr("\"end_time\":\"2027-01-15T08:00:00Z\""));
  EXPECT_THAT(body, HasSubstr("\"message\":\"strength_attribute 'w': no such attribute\""));
  EXPECT_THAT(body, ::testing::Not(HasSubstr("secret-path")));
  EXPECT_THAT(body, ::testing::Not(HasSubstr("spec")));
}

}  // namespace
}  // namespace meshsmooth::server
