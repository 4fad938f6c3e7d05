// Test fixtures for the CanopenMaster tests: a unique UDP multicast bus per test, a tiny CANopen
// node (object dictionary map + the library's SdoServer + a frame log) on its own channel and
// thread, a recording NodeObserver and a channel wrapper that injects bus faults.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <utility>
#include <vector>

#include "adapters/canopen/master.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::canopen::testing {

using namespace std::chrono_literals;

// A bus on a group of its own and a random port, so parallel test processes never share one.
CanBusConfig UniqueBus();

// Polls `pred` until it holds or `timeout` passes (never a fixed sleep as an assertion).
template <typename Pred>
bool WaitFor(Pred pred, std::chrono::milliseconds timeout = 5000ms) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(1ms);
  }
  return pred();
}

// A deadline far enough away not to matter (the per-frame SDO timeout bounds the call).
inline TimePoint Far() { return SteadyClock::Instance().Now() + 20s; }

// One CANopen node: answers SDO requests on 600h + id from a map (unless silent or holding),
// logs every frame it sees, sends what the test asks for.
class TestNode final : public ObjectAccess {
 public:
  static std::unique_ptr<TestNode> Start(const CanBusConfig& bus, uint8_t node);
  ~TestNode() override;

  uint8_t id() const { return node_; }
  void Set(uint16_t index, uint8_t sub, std::vector<uint8_t> value, bool read_only = false);
  std::optional<std::vector<uint8_t>> Get(uint16_t index, uint8_t sub) const;
  // Writes to index:sub store `stored` instead of the written bytes (a node that rounds).
  void StoreOnWrite(uint16_t index, uint8_t sub, std::vector<uint8_t> stored);
  // Requests for index:sub are answered with this abort.
  void AbortOn(uint16_t index, uint8_t sub, SdoAbortCode code);
  // Silent: SDO requests are logged and never answered.
  void SetSilent(bool silent);
  // Holding: SDO requests are logged and kept; Release() answers them in order (and holds the
  // next ones too when `keep_holding`).
  void SetHolding(bool holding);
  void Release(bool keep_holding = false);
  size_t held() const;
  // Lost frames (decision 1481's retry tests): the next `n` SDO requests are logged and never
  // reach the server; the next `n` answers are computed (writes happen) and never sent.
  void DropRequests(int n);
  void DropAnswers(int n);

  // Every successful write, in order.
  std::vector<SdoWrite> writes() const;
  // Every frame the node saw on the bus.
  std::vector<transport::CanFrame> frames() const;
  std::vector<transport::CanFrame> frames_with_id(uint32_t id) const;
  // Initiate requests that arrived while the server was in a segmented transfer.
  uint64_t overlaps() const { return overlaps_.load(); }

  void Send(const transport::CanFrame& frame);
  void SendHeartbeat(NmtState state);
  void SendEmcy(uint16_t code, uint8_t error_register, std::array<uint8_t, 5> manufacturer = {});

  absl::StatusOr<std::vector<uint8_t>> Read(uint16_t index, uint8_t sub) override;
  absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) override;

 private:
  TestNode(std::unique_ptr<transport::CanChannel> channel, uint8_t node);
  void Run();
  void Answer(const transport::CanFrame& frame);

  std::unique_ptr<transport::CanChannel> channel_;
  const uint8_t node_;
  SdoServer server_;
  mutable std::mutex mu_;
  struct Entry {
    std::vector<uint8_t> value;
    bool read_only = false;
  };
  std::map<std::pair<uint16_t, uint8_t>, Entry> objects_;
  std::map<std::pair<uint16_t, uint8_t>, std::vector<uint8_t>> store_on_write_;
  std::map<std::pair<uint16_t, uint8_t>, SdoAbortCode> aborts_;
  std::vector<SdoWrite> writes_;
  std::vector<transport::CanFrame> frames_;
  std::vector<transport::CanFrame> held_;
  bool silent_ = false;
  bool holding_ = false;
  int drop_requests_ = 0;
  std::atomic<int> drop_answers_{0};
  std::atomic<uint64_t> overlaps_{0};
  std::atomic<bool> stop_{false};
  std::mutex server_mu_;  // the SdoServer: node thread and Release()
  std::thread thread_;
};

// Records every notification.
class RecordingObserver final : public NodeObserver {
 public:
  void OnHeartbeat(uint8_t node, NmtState state, TimePoint at) noexcept override;
  void OnBootUp(const NodeEventInfo& event) noexcept override;
  void OnEmcy(const EmcyEvent& event) noexcept override;
  void OnTpdo(const TpdoEvent& event) noexcept override;
  void OnLinkEvent(const NodeEventInfo& event) noexcept override;

  size_t heartbeats() const;
  std::vector<NodeEvent> events() const;  // boot-ups and link events, in order
  std::vector<NodeEventInfo> infos() const;
  std::vector<EmcyEvent> emcys() const;
  std::vector<TpdoEvent> tpdos() const;
  bool HasEvent(NodeEvent e) const;

  // Runs on the receive thread inside OnHeartbeat (tests calling back into the master).
  std::function<void()> on_heartbeat;

 private:
  mutable std::mutex mu_;
  size_t heartbeats_ = 0;
  std::vector<NodeEventInfo> events_;
  std::vector<EmcyEvent> emcys_;
  std::vector<TpdoEvent> tpdos_;
};

// Faults shared by every FaultyChannel of one test (the master reopens new ones).
struct Faults {
  // Frames Receive returns before the bus's (error frames come from the controller, never over
  // the bus); call the master's Wake() after adding.
  void Inject(const transport::CanFrame& frame) {
    std::lock_guard lock(inject_mu);
    inject.push_back(frame);
  }
  std::mutex inject_mu;
  std::deque<transport::CanFrame> inject;
  std::atomic<bool> fail_receive{false};
  std::atomic<int> state{-1};  // -1: the inner channel's state, else a CanBusState
  std::atomic<int> opened{0};
};

class FaultyChannel final : public transport::CanChannel {
 public:
  FaultyChannel(std::unique_ptr<transport::CanChannel> inner, std::shared_ptr<Faults> faults)
      : inner_(std::move(inner)), faults_(std::move(faults)) {
    faults_->opened.fetch_add(1);
  }
  absl::Status Send(const transport::CanFrame& frame) override;
  absl::StatusOr<std::optional<transport::CanFrame>> Receive(
      std::chrono::nanoseconds timeout) override;
  void Wake() override { inner_->Wake(); }
  absl::Status SetFilters(std::span<const transport::CanFilter> filters) override {
    return inner_->SetFilters(filters);
  }
  transport::CanBusState state() const override;
  transport::CanCounters counters() const override { return inner_->counters(); }
  std::string name() const override { return inner_->name(); }

 private:
  std::unique_ptr<transport::CanChannel> inner_;
  std::shared_ptr<Faults> faults_;
};

}  // namespace drivegw::canopen::testing
