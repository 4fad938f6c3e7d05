// Test fixtures of the CanopenMaster tests (test_node.h).
#include "tests/adapters/canopen/master/test_node.h"

#include <unistd.h>

#include <random>

#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/emcy.h"
#include "adapters/canopen/nmt.h"

namespace drivegw::canopen::testing {

CanBusConfig UniqueBus() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  CanBusConfig c;
  c.kind = CanBusConfig::Kind::kUdpMulticast;
  c.group = "239.74.163.111";  // this suite's group; ports are random per test
  c.port = static_cast<uint16_t>(20000 + rng() % 30000);
  return c;
}

// ---------------------------------------------------------------------------------------------
// TestNode.

std::unique_ptr<TestNode> TestNode::Start(const CanBusConfig& bus, uint8_t node) {
  auto channel = transport::OpenCanChannel(bus);
  if (!channel.ok()) return nullptr;
  std::unique_ptr<TestNode> n(new TestNode(*std::move(channel), node));
  n->thread_ = std::thread([p = n.get()] { p->Run(); });
  return n;
}

TestNode::TestNode(std::unique_ptr<transport::CanChannel> channel, uint8_t node)
    : channel_(std::move(channel)), node_(node), server_(*DefaultSdoChannel(node), *this) {}

TestNode::~TestNode() {
  stop_ = true;
  channel_->Wake();
  if (thread_.joinable()) thread_.join();
}

void TestNode::Set(uint16_t index, uint8_t sub, std::vector<uint8_t> value, bool read_only) {
  std::lock_guard lock(mu_);
  objects_[{index, sub}] = Entry{std::move(value), read_only};
}

std::optional<std::vector<uint8_t>> TestNode::Get(uint16_t index, uint8_t sub) const {
  std::lock_guard lock(mu_);
  auto it = objects_.find({index, sub});
  if (it == objects_.end()) return std::nullopt;
  return it->second.value;
}

void TestNode::StoreOnWrite(uint16_t index, uint8_t sub, std::vector<uint8_t> stored) {
  std::lock_guard lock(mu_);
  store_on_write_[{index, sub}] = std::move(stored);
}

void TestNode::AbortOn(uint16_t index, uint8_t sub, SdoAbortCode code) {
  std::lock_guard lock(mu_);
  aborts_[{index, sub}] = code;
}

void TestNode::SetSilent(bool silent) {
  std::lock_guard lock(mu_);
  silent_ = silent;
}

void TestNode::SetHolding(bool holding) {
  std::lock_guard lock(mu_);
  holding_ = holding;
}

void TestNode::Release(bool keep_holding) {
  std::vector<transport::CanFrame> held;
  {
    std::lock_guard lock(mu_);
    held.swap(held_);
    holding_ = keep_holding;
  }
  for (const auto& f : held) Answer(f);
}

void TestNode::DropRequests(int n) {
  std::lock_guard lock(mu_);
  drop_requests_ = n;
}

void TestNode::DropAnswers(int n) { drop_answers_.store(n); }

size_t TestNode::held() const {
  std::lock_guard lock(mu_);
  return held_.size();
}

std::vector<SdoWrite> TestNode::writes() const {
  std::lock_guard lock(mu_);
  return writes_;
}

std::vector<transport::CanFrame> TestNode::frames() const {
  std::lock_guard lock(mu_);
  return frames_;
}

std::vector<transport::CanFrame> TestNode::frames_with_id(uint32_t id) const {
  std::lock_guard lock(mu_);
  std::vector<transport::CanFrame> out;
  for (const auto& f : frames_) {
    if (f.id == id) out.push_back(f);
  }
  return out;
}

void TestNode::Send(const transport::CanFrame& frame) {
  absl::Status s = channel_->Send(frame);
  (void)s;
}

void TestNode::SendHeartbeat(NmtState state) {
  Send(*EncodeErrorControl(ErrorControl{node_, state, false}));
}

void TestNode::SendEmcy(uint16_t code, uint8_t error_register,
                        std::array<uint8_t, 5> manufacturer) {
  Send(*EncodeEmcy(Emcy{node_, code, error_register, manufacturer}));
}

absl::StatusOr<std::vector<uint8_t>> TestNode::Read(uint16_t index, uint8_t sub) {
  std::lock_guard lock(mu_);
  if (auto a = aborts_.find({index, sub}); a != aborts_.end()) {
    return SdoAbortStatus(a->second, "test node");
  }
  auto it = objects_.find({index, sub});
  if (it == objects_.end()) return SdoAbortStatus(SdoAbortCode::kNoObject, "test node");
  return it->second.value;
}

absl::Status TestNode::Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) {
  std::lock_guard lock(mu_);
  if (auto a = aborts_.find({index, sub}); a != aborts_.end()) {
    return SdoAbortStatus(a->second, "test node");
  }
  auto it = objects_.find({index, sub});
  if (it != objects_.end() && it->second.read_only) {
    return SdoAbortStatus(SdoAbortCode::kReadOnly, "test node");
  }
  std::vector<uint8_t> value(data.begin(), data.end());
  writes_.push_back(SdoWrite{index, sub, value});
  if (auto s = store_on_write_.find({index, sub}); s != store_on_write_.end()) value = s->second;
  objects_[{index, sub}].value = std::move(value);
  return absl::OkStatus();
}

void TestNode::Answer(const transport::CanFrame& frame) {
  std::optional<transport::CanFrame> reply;
  {
    std::lock_guard lock(server_mu_);
    const uint8_t ccs = frame.data[0] >> 5;
    // ccs 1 initiate download, 2 initiate upload (CiA 301 §7.2.4.3).
    if ((ccs == 1 || ccs == 2) && server_.busy()) overlaps_.fetch_add(1);
    reply = server_.OnFrame(frame);
  }
  if (reply && drop_answers_.load() > 0) {
    drop_answers_.fetch_sub(1);
    return;
  }
  if (reply) Send(*reply);
}

void TestNode::Run() {
  const uint32_t request_id = 0x600u + node_;
  while (!stop_) {
    auto got = channel_->Receive(50ms);
    if (!got.ok() || !got->has_value()) continue;
    const transport::CanFrame f = **got;
    bool answer = false;
    {
      std::lock_guard lock(mu_);
      frames_.push_back(f);
      if (f.id == request_id && !f.rtr) {
        if (drop_requests_ > 0) {
          --drop_requests_;
        } else if (holding_) {
          held_.push_back(f);
        } else {
          answer = !silent_;
        }
      }
    }
    if (answer) Answer(f);
  }
}

// ---------------------------------------------------------------------------------------------
// RecordingObserver.

void RecordingObserver::OnHeartbeat(uint8_t, NmtState, TimePoint) noexcept {
  {
    std::lock_guard lock(mu_);
    ++heartbeats_;
  }
  if (on_heartbeat) on_heartbeat();
}

void RecordingObserver::OnBootUp(const NodeEventInfo& event) noexcept {
  std::lock_guard lock(mu_);
  events_.push_back(event);
}

void RecordingObserver::OnEmcy(const EmcyEvent& event) noexcept {
  std::lock_guard lock(mu_);
  emcys_.push_back(event);
}

void RecordingObserver::OnTpdo(const TpdoEvent& event) noexcept {
  std::lock_guard lock(mu_);
  tpdos_.push_back(event);
}

void RecordingObserver::OnLinkEvent(const NodeEventInfo& event) noexcept {
  std::lock_guard lock(mu_);
  events_.push_back(event);
}

size_t RecordingObserver::heartbeats() const {
  std::lock_guard lock(mu_);
  return heartbeats_;
}

std::vector<NodeEvent> RecordingObserver::events() const {
  std::lock_guard lock(mu_);
  std::vector<NodeEvent> out;
  for (const auto& e : events_) out.push_back(e.event);
  return out;
}

std::vector<NodeEventInfo> RecordingObserver::infos() const {
  std::lock_guard lock(mu_);
  return events_;
}

std::vector<EmcyEvent> RecordingObserver::emcys() const {
  std::lock_guard lock(mu_);
  return emcys_;
}

std::vector<TpdoEvent> RecordingObserver::tpdos() const {
  std::lock_guard lock(mu_);
  return tpdos_;
}

bool RecordingObserver::HasEvent(NodeEvent e) const {
  std::lock_guard lock(mu_);
  for (const auto& x : events_) {
    if (x.event == e) return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// FaultyChannel.

absl::Status FaultyChannel::Send(const transport::CanFrame& frame) {
  const int s = faults_->state.load();
  if (s == static_cast<int>(transport::CanBusState::kBusOff) ||
      s == static_cast<int>(transport::CanBusState::kDown)) {
    return absl::UnavailableError("injected: bus-off");
  }
  return inner_->Send(frame);
}

absl::StatusOr<std::optional<transport::CanFrame>> FaultyChannel::Receive(
    std::chrono::nanoseconds timeout) {
  if (faults_->fail_receive.load()) return absl::InternalError("injected receive failure");
  {
    std::lock_guard lock(faults_->inject_mu);
    if (!faults_->inject.empty()) {
      const transport::CanFrame f = faults_->inject.front();
      faults_->inject.pop_front();
      return std::optional<transport::CanFrame>(f);
    }
  }
  return inner_->Receive(timeout);
}

transport::CanBusState FaultyChannel::state() const {
  const int s = faults_->state.load();
  return s < 0 ? inner_->state() : static_cast<transport::CanBusState>(s);
}

}  // namespace drivegw::canopen::testing
