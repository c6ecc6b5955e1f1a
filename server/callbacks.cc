#include "server/callbacks.h"

#include <curl/curl.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <map>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "core/io/formats.h"
#include "google/protobuf/util/json_util.h"
#include "server/convert.h"
#include "server/log.h"

namespace meshsmooth::server {
namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kMaxUrlLength = 2048;

absl::Status BadUrl(std::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat("callback_url ", io::Sv(why)));
}

// The answer's body is not read: it goes nowhere (libcurl's default would write it on stdout).
size_t Discard(char*, size_t size, size_t count, void*) { return size * count; }

// A receiver that may take it later: no answer, a timeout, 408, 429 or a 5xx.
bool WorthRetrying(CURLcode code, long http) {
  if (code != CURLE_OK) return true;
  return http == 408 || http == 429 || http >= 500;
}

}  // namespace

absl::Status CheckCallbackUrl(std::string_view url) {
  if (url.size() > kMaxUrlLength) {
    return BadUrl(absl::StrCat("is ", url.size(), " characters long; at most ", kMaxUrlLength));
  }
  std::unique_ptr<CURLU, void (*)(CURLU*)> parsed(curl_url(), curl_url_cleanup);
  if (parsed == nullptr) return absl::ResourceExhaustedError("no memory to parse callback_url");
  const std::string copy(url);
  if (CURLUcode c = curl_url_set(parsed.get(), CURLUPART_URL, copy.c_str(), 0); c != CURLUE_OK) {
    return BadUrl(absl::StrCat("'", copy, "' is not a URL (", curl_url_strerror(c), ")"));
  }
  char* scheme = nullptr;
  curl_url_get(parsed.get(), CURLUPART_SCHEME, &scheme, 0);
  const std::string s = scheme != nullptr ? scheme : "";
  curl_free(scheme);
  if (s != "http" && s != "https") {
    return BadUrl(absl::StrCat("'", copy, "' is a ", s, " URL: callbacks go to http:// or https:// only"));
  }
  char* host = nullptr;
  const CURLUcode has_host = curl_url_get(parsed.get(), CURLUPART_HOST, &host, 0);
  const bool empty = has_host != CURLUE_OK || host == nullptr || host[0] == '\0';
  curl_free(host);
  if (empty) return BadUrl(absl::StrCat("'", copy, "' names no host"));
  return absl::OkStatus();
}

std::string CallbackBody(const v1::Job& job) {
  v1::Job sent = job;
  sent.clear_spec();  // the client's own, and it holds the URL
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  std::string body;
  (void)google::protobuf::util::MessageToJsonString(sent, &body, options);  // fails only on unset Any
  return body;
}

std::string CallbackSignature(std::string_view secret, std::string_view body) {
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()),
       reinterpret_cast<const unsigned char*>(body.data()), body.size(), mac, &length);
  return absl::StrCat("sha256=", absl::BytesToHexString(absl::string_view(reinterpret_cast<const char*>(mac), length)));
}

// One callback, from its first POST to its last.
struct CallbackSender::Delivery {
  std::string job_id, state, url, body, signature;
  int attempts = 0;  // POSTs started
  Clock::time_point due;
  CURL* easy = nullptr;
  curl_slist* headers = nullptr;
  char error[CURL_ERROR_SIZE] = {};

  ~Delivery() {
    if (easy != nullptr) curl_easy_cleanup(easy);
    curl_slist_free_all(headers);
  }
};

CallbackSender::CallbackSender(std::string secret, LogFormat log_format, CallbackOptions options)
    : secret_(std::move(secret)), log_format_(log_format), options_(options) {
  curl_global_init(CURL_GLOBAL_DEFAULT);  // thread-safe since libcurl 7.84; Debian 12 has 7.88
  multi_ = curl_multi_init();
  thread_ = std::thread([this] { Loop(); });
}

CallbackSender::~CallbackSender() { Stop(); }

void CallbackSender::Send(const v1::Job& job) {
  auto d = std::make_unique<Delivery>();
  d->job_id = job.job_id();
  d->state = JobStateName(job.state());
  d->url = job.spec().callback_url();
  d->body = CallbackBody(job);
  d->signature = CallbackSignature(secret_, d->body);
  d->due = Clock::now();
  std::lock_guard<std::mutex> lock(mu_);
  if (stopping_) {
    LogJobEvent(log_format_, "warning", "callback", d->job_id, "callback dropped: the server is stopping",
                [](JsonLine& l) { l.Int("attempt", 0).Int("http_status", 0).Str("outcome", "dropped"); });
    return;
  }
  incoming_.push_back(std::move(d));
  curl_multi_wakeup(static_cast<CURLM*>(multi_));
}

void CallbackSender::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_) return;
    stopping_ = true;
    curl_multi_wakeup(static_cast<CURLM*>(multi_));
  }
  if (thread_.joinable()) thread_.join();
  curl_multi_cleanup(static_cast<CURLM*>(multi_));
  multi_ = nullptr;
}

void CallbackSender::Loop() {
  CURLM* multi = static_cast<CURLM*>(multi_);
  std::vector<std::unique_ptr<Delivery>> waiting;        // until their `due`
  std::map<CURL*, std::unique_ptr<Delivery>> in_flight;  // by their handle
  const auto log = [this](const Delivery& d, std::string_view level, std::string_view outcome, long http,
                          const std::string& why) {
    std::string message = absl::StrCat("callback for ", d.state, " ", io::Sv(outcome), " (attempt ", d.attempts, " of ",
                                       options_.attempts);
    if (http > 0) absl::StrAppend(&message, ", HTTP ", http);
    absl::StrAppend(&message, ")");
    if (!why.empty()) absl::StrAppend(&message, ": ", why);
    LogJobEvent(log_format_, level, "callback", d.job_id, message, [&](JsonLine& l) {
      l.Int("attempt", d.attempts).Int("http_status", http).Str("outcome", outcome).Str("error", why);
    });
  };
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stopping_) break;
      for (auto& d : incoming_) waiting.push_back(std::move(d));
      incoming_.clear();
    }
    // Start every delivery that is due.
    const Clock::time_point now = Clock::now();
    for (auto it = waiting.begin(); it != waiting.end();) {
      if ((*it)->due > now) {
        ++it;
        continue;
      }
      Delivery& d = **it;
      ++d.attempts;
      d.easy = curl_easy_init();
      if (d.headers == nullptr) {
        d.headers = curl_slist_append(d.headers, "Content-Type: application/json");
        d.headers = curl_slist_append(d.headers, absl::StrCat("X-Meshsmooth-Signature: ", d.signature).c_str());
        d.headers = curl_slist_append(d.headers, "Expect:");  // no 100-continue round trip
      }
      curl_easy_setopt(d.easy, CURLOPT_URL, d.url.c_str());
      curl_easy_setopt(d.easy, CURLOPT_PROTOCOLS_STR, "http,https");
      curl_easy_setopt(d.easy, CURLOPT_POSTFIELDS, d.body.data());
      curl_easy_setopt(d.easy, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(d.body.size()));
      curl_easy_setopt(d.easy, CURLOPT_HTTPHEADER, d.headers);
      curl_easy_setopt(d.easy, CURLOPT_USERAGENT, "meshsmoothd");
      curl_easy_setopt(d.easy, CURLOPT_TIMEOUT_MS, static_cast<long>(options_.request_timeout.count()));
      curl_easy_setopt(d.easy, CURLOPT_CONNECTTIMEOUT_MS, static_cast<long>(options_.connect_timeout.count()));
      curl_easy_setopt(d.easy, CURLOPT_NOSIGNAL, 1L);
      curl_easy_setopt(d.easy, CURLOPT_WRITEFUNCTION, Discard);
      curl_easy_setopt(d.easy, CURLOPT_ERRORBUFFER, d.error);
      curl_multi_add_handle(multi, d.easy);
      in_flight.emplace(d.easy, std::move(*it));
      it = waiting.erase(it);
    }
    int running = 0;
    curl_multi_perform(multi, &running);
    int left = 0;
    while (CURLMsg* msg = curl_multi_info_read(multi, &left)) {
      if (msg->msg != CURLMSG_DONE) continue;
      auto node = in_flight.extract(msg->easy_handle);
      std::unique_ptr<Delivery> d = std::move(node.mapped());
      const CURLcode code = msg->data.result;
      long http = 0;
      if (code == CURLE_OK) curl_easy_getinfo(d->easy, CURLINFO_RESPONSE_CODE, &http);
      curl_multi_remove_handle(multi, d->easy);
      curl_easy_cleanup(d->easy);
      d->easy = nullptr;
      if (code == CURLE_OK && http >= 200 && http < 300) {
        log(*d, "info", "delivered", http, "");
        continue;
      }
      const std::string why = code != CURLE_OK ? std::string(d->error[0] != '\0' ? d->error : curl_easy_strerror(code))
                                               : absl::StrCat("the receiver answered HTTP ", http);
      if (!WorthRetrying(code, http) || d->attempts >= options_.attempts) {
        log(*d, "warning", "gave_up", http, why);
        continue;
      }
      const auto delay =
          std::min(options_.max_delay, options_.first_delay * (int64_t{1} << std::min(d->attempts - 1, 20)));
      log(*d, "warning", "retry", http, absl::StrCat(why, "; next in ", delay.count() / 1000.0, " s"));
      d->due = Clock::now() + delay;
      waiting.push_back(std::move(d));
    }
    // Sleep until a socket is ready, the next retry is due or Send/Stop wakes the thread.
    auto wait = std::chrono::milliseconds(1000);
    for (const auto& d : waiting) {
      wait = std::min(wait, std::chrono::duration_cast<std::chrono::milliseconds>(d->due - Clock::now()));
    }
    curl_multi_poll(multi, nullptr, 0, static_cast<int>(std::max<int64_t>(wait.count(), 0)), nullptr);
  }
  for (auto& [easy, d] : in_flight) {
    curl_multi_remove_handle(multi, easy);
    log(*d, "warning", "dropped", 0, "the server is stopping");
  }
  for (auto& d : waiting) log(*d, "warning", "dropped", 0, "the server is stopping");
}

}  // namespace meshsmooth::server
