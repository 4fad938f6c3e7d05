// A ResponseSink for router tests: records the response, stream lines and end, with waits that
// have a deadline; with auto_next it asks for every stream message as it arrives.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "server/rest/router.h"

namespace drivegw::rest::test_support {

// Records what the router hands a session; with auto_next it asks for every message.
class RecordingSink final : public ResponseSink {
 public:
  explicit RecordingSink(bool auto_next = true) : auto_next_(auto_next) {}

  void OnResponse(HttpResponse response) noexcept override {
    Set([&] { response_ = std::move(response); });
  }
  void OnStreamStarted(std::shared_ptr<StreamCall> stream) noexcept override {
    Set([&] { stream_ = stream; });
    if (auto_next_) stream->RequestNext();
  }
  void OnStreamMessage(std::string line) noexcept override {
    std::shared_ptr<StreamCall> stream;
    Set([&] {
      lines_.push_back(std::move(line));
      stream = stream_;
    });
    if (auto_next_ && stream) stream->RequestNext();
  }
  void OnStreamEnd(HttpResponse end) noexcept override {
    Set([&] {
      end_ = std::move(end);
      stream_.reset();
    });
  }

  // Waits for a whole response (fails the test after 10 s).
  HttpResponse Response() {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(
        cv_.wait_for(lock, std::chrono::seconds(10), [&] { return response_.has_value(); }));
    return response_.value_or(HttpResponse{0, "", "timeout", {}});
  }
  HttpResponse End() {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, std::chrono::seconds(10), [&] { return end_.has_value(); }));
    return end_.value_or(HttpResponse{0, "", "timeout", {}});
  }
  bool WaitLines(size_t n) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, std::chrono::seconds(10), [&] { return lines_.size() >= n; });
  }
  std::vector<std::string> lines() {
    std::lock_guard lock(mu_);
    return lines_;
  }
  std::shared_ptr<StreamCall> stream() {
    std::lock_guard lock(mu_);
    return stream_;
  }
  bool has_response() {
    std::lock_guard lock(mu_);
    return response_.has_value();
  }

 private:
  template <typename F>
  void Set(F f) {
    {
      std::lock_guard lock(mu_);
      f();
    }
    cv_.notify_all();
  }

  const bool auto_next_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::optional<HttpResponse> response_;
  std::shared_ptr<StreamCall> stream_;
  std::vector<std::string> lines_;
  std::optional<HttpResponse> end_;
};

}  // namespace drivegw::rest::test_support
