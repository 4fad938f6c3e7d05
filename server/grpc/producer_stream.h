// A server stream fed by a producer thread: the body runs the core's loop (watch or export audit
// events; WatchDrives runs on the shared ticker instead, decision 1341) and hands each message to
// gRPC one write at a time — the producer waits while a write is in flight, so memory per stream
// is one message; the core coalesces meanwhile.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "grpcpp/grpcpp.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {

template <typename Message>
class ProducerStream final : public grpc::ServerWriteReactor<Message> {
 public:
  // Returns false once the client is gone (stop producing).
  using Sink = std::function<bool(const Message&)>;
  using Body =
      std::function<absl::Status(const Sink& sink, const std::function<bool()>& cancelled)>;

  // Create with `new`: the callback API's reactor owns itself until OnDone.
  explicit ProducerStream(Body body) {
    producer_ = std::thread([this, body = std::move(body)] {
      absl::Status s =
          body([this](const Message& m) { return Write(m); }, [this] { return cancelled_.load(); });
      // The last write must be done before Finish.
      {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return !writing_ || cancelled_.load(); });
      }
      this->Finish(ToGrpcStatus(s));
    });
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mu_);
    writing_ = false;
    if (!ok) cancelled_.store(true);
    cv_.notify_all();
  }
  void OnCancel() override {
    cancelled_.store(true);
    std::lock_guard lock(mu_);
    cv_.notify_all();
  }
  void OnDone() override {
    cancelled_.store(true);
    // gRPC may run OnDone inline on the producer thread (from Finish); it cannot join itself.
    if (producer_.joinable()) {
      if (producer_.get_id() == std::this_thread::get_id()) {
        producer_.detach();
      } else {
        producer_.join();
      }
    }
    delete this;
  }

 private:
  bool Write(const Message& m) {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !writing_ || cancelled_.load(); });
    if (cancelled_.load()) return false;
    current_ = m;
    writing_ = true;
    lock.unlock();
    this->StartWrite(&current_);
    return true;
  }

  std::mutex mu_;
  std::condition_variable cv_;
  bool writing_ = false;
  std::atomic<bool> cancelled_{false};
  Message current_;
  std::thread producer_;
};

}  // namespace drivegw::server
