// DnStack: the DeviceNet side of the simulated drive, pure (no I/O, time passed in): network
// start-up with the duplicate MAC ID check, Allocate/Release of the predefined master/slave
// connection set, explicit messaging (Get/Set_Attribute_Single, fragmentation), connection
// objects with the 4 x EPR watchdog, poll and CoS/cyclic I/O with fragmentation, bus-off and
// fault injection (linmot-devicenet.md §5, §10.2, §12.2-§12.4, §12.6, §12.8).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec.h"
#include "sim/linmot_devicenet/io_application.h"
#include "sim/linmot_devicenet/options.h"
#include "sim/linmot_devicenet/snapshot.h"

namespace drivegw::sim::linmot_devicenet {

// A frame the stack wants on the bus, not before `due` (poll responses with an injected or
// configured delay; everything else due at once).
struct OutFrame {
  dn::Frame frame;
  TimePoint due{};
};

// Fault injection on the DeviceNet side (§12.8).
struct StackFaults {
  bool drop_polls = false;         // complete polls are discarded unanswered (not consumed)
  uint32_t drop_next_polls = 0;    // the next n complete polls are discarded
  Duration response_delay{0};      // added to options.response_delay
  bool corrupt_fragments = false;  // fragmented responses lose a middle (or the last) fragment
  int response_length_delta = 0;   // poll responses carry produced size + delta bytes
  bool lonely_node = false;        // the duplicate MAC check is never acknowledged (0x8143)
};

class DnStack {
 public:
  // `options` must be valid (ValidateOptions); `app` must outlive the stack.
  DnStack(const DnSimOptions& options, IoApplication& app);

  // Power-up of the network side: with dn.enable the duplicate MAC check starts at `now`
  // (first request now, §5.7); disabled drives stay silent (§10.2).
  std::vector<OutFrame> Start(TimePoint now);
  // One received frame (already a DeviceNet 11-bit data frame).
  std::vector<OutFrame> HandleFrame(const dn::Frame& frame, TimePoint now);
  // Timers: duplicate MAC check, watchdogs, CoS/cyclic production, bus-off recovery.
  std::vector<OutFrame> Advance(TimePoint now);
  // The earliest time Advance has work, if any (besides CoS change detection).
  std::optional<TimePoint> NextDeadline() const;

  // Controller restart (0x0F, identity Reset): every connection dropped, the check again.
  std::vector<OutFrame> Restart(TimePoint now);
  // §5.10: stop transmitting, drop every connection, bus-off counter + 1, 0x8148 (D-16).
  void GoBusOff(TimePoint now);
  // CAN controller reset after bus-off: the duplicate MAC check again; application kept.
  std::vector<OutFrame> RecoverBusOff(TimePoint now);
  // TC-10 without a second node: the check restarts and is answered -> faulted, 0x8101.
  std::vector<OutFrame> InjectDuplicateMac(TimePoint now);

  StackFaults& faults() { return faults_; }
  const StackFaults& faults() const { return faults_; }
  NetworkState network() const { return network_; }
  uint8_t mac_id() const { return mac_; }
  std::optional<uint8_t> owner() const { return owner_; }
  uint8_t allocation_choice() const { return allocated_; }
  StackSnapshot Snapshot() const;
  const StackCounters& counters() const { return counters_; }

 private:
  struct Connection {
    uint8_t instance = 0;
    ConnectionState state = ConnectionState::kNonExistent;
    uint16_t epr_ms = 0;
    uint8_t watchdog_action = 0;  // 0 timed out, 1 auto delete, 2 auto reset, 3 deferred delete
    uint16_t inhibit_ms = 0;
    uint16_t produced_size = 0;
    uint16_t consumed_size = 0;
    TimePoint last_activity{};
    uint64_t received = 0;
    uint64_t sent = 0;
    uint64_t timeouts = 0;
    dn::Reassembler reassembler{dn::kMaxFragmentedMessage};  // consumed fragments
    std::optional<dn::Fragmenter> fragmenter;  // explicit: outgoing fragmented response
    std::vector<uint8_t> last_produced;        // CoS: change detection
    std::optional<TimePoint> last_production;
  };

  void Emit(std::vector<OutFrame>& out, uint16_t id, std::span<const uint8_t> bytes, TimePoint due);
  void StartDuplicateCheck(std::vector<OutFrame>& out, TimePoint now);
  void SendDuplicateCheck(std::vector<OutFrame>& out, bool response, TimePoint now);
  void DropAllConnections();
  void ReleaseBits(uint8_t bits);
  void UpdateIoConnected();
  bool Consuming(const Connection& c) const;
  Connection* ConnectionByInstance(uint16_t instance);

  void OnDuplicateMac(std::span<const uint8_t> payload, std::vector<OutFrame>& out, TimePoint now);
  void OnUnconnected(std::span<const uint8_t> payload, std::vector<OutFrame>& out, TimePoint now);
  void OnExplicit(std::span<const uint8_t> payload, std::vector<OutFrame>& out, TimePoint now);
  void OnIo(std::span<const uint8_t> payload, std::vector<OutFrame>& out, TimePoint now);
  void OnCosAck(TimePoint now);
  void OnUcmm(uint8_t client, std::span<const uint8_t> payload, std::vector<OutFrame>& out,
              TimePoint now);

  // Explicit services; return the response message (header first).
  dn::ExplicitResponse Allocate(const dn::ExplicitRequest& request, TimePoint now);
  dn::ExplicitResponse Release(const dn::ExplicitRequest& request);
  dn::ExplicitResponse Service(const dn::ExplicitRequest& request, TimePoint now,
                               bool* reset_after);
  dn::ExplicitResponse GetAttribute(const dn::ExplicitRequest& request);
  dn::ExplicitResponse SetAttribute(const dn::ExplicitRequest& request, TimePoint now);
  void SendExplicit(const dn::ExplicitResponse& response, std::vector<OutFrame>& out,
                    TimePoint now);
  dn::ExplicitResponse Error(dn::ExplicitHeader header, uint8_t general, uint8_t additional);

  void Produce(Connection& c, IoConnection which, uint16_t id, std::vector<OutFrame>& out,
               TimePoint now, bool apply_faults);
  void RunWatchdogs(TimePoint now);
  void RunCos(std::vector<OutFrame>& out, TimePoint now);

  const DnSimOptions options_;
  IoApplication& app_;
  const uint8_t mac_;
  const dn::PredefinedIds ids_;
  StackFaults faults_;

  NetworkState network_ = NetworkState::kDisabled;
  int dup_requests_sent_ = 0;
  TimePoint dup_next_{};
  bool lonely_reported_ = false;
  std::optional<TimePoint> bus_off_since_;
  bool boi_ = false;
  uint8_t bus_off_count_ = 0;

  std::optional<uint8_t> owner_;
  uint8_t allocated_ = 0;  // §5.5 choice bits currently allocated
  bool io_connected_ = false;
  Connection explicit_;
  Connection poll_;
  Connection cos_;
  StackCounters counters_;
};

}  // namespace drivegw::sim::linmot_devicenet
