// LinMotDnServer: one simulated LinMot DeviceNet drive on a real CAN channel (UDP multicast bus
// or SocketCAN): one thread receives frames, advances the device to the injected clock, runs
// the DeviceNet stack and sends its frames; plus fault injection (linmot-devicenet.md §12).
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/transport/can_channel.h"
#include "sim/linmot_devicenet/options.h"
#include "sim/linmot_devicenet/snapshot.h"

namespace drivegw::sim::linmot_devicenet {

class LinMotDnDevice;
class DnStack;
struct OutFrame;

// Thread model: one I/O thread owns the Receive loop; every public method is thread-safe and
// serialised with it by one mutex. The device is advanced to clock.Now() in fixed ticks before
// every frame and every hook, and the stack's timers (duplicate MAC check, 4 x EPR watchdogs,
// CoS heartbeat) run on the same clock, which the thread re-reads at least every 5 ms of real
// time, so a test's ManualClock::Advance takes effect without any sleeping in the simulator.
class LinMotDnServer {
 public:
  // Validates the options, creates device and stack, opens the channel from options.can unless
  // one is injected (tests), and starts the thread. The drive begins its network start-up at
  // once (duplicate MAC check, §12.2). `clock` must outlive the server.
  static absl::StatusOr<std::unique_ptr<LinMotDnServer>> Start(
      const DnSimOptions& options, const Clock& clock,
      std::unique_ptr<transport::CanChannel> channel = nullptr);
  ~LinMotDnServer();  // Stop()
  LinMotDnServer(const LinMotDnServer&) = delete;
  LinMotDnServer& operator=(const LinMotDnServer&) = delete;

  // Stops the thread and closes the channel; idempotent.
  void Stop();

  const DnSimOptions& options() const { return options_; }
  uint8_t mac_id() const { return mac_id_; }
  std::string bus_name() const;  // "udp:239.74.163.2:43113", "vcan0"

  // ---- observation (§12.7) ----
  DnSimSnapshot Snapshot();
  // The last `max_frames` frames in and out (oldest first); bounded ring, 4096 by default.
  std::vector<FrameRecord> Frames() const;
  void ClearFrames();

  // ---- fault injection (§12.8); all act at clock.Now() ----
  // Poll commands are received (they feed the watchdog) but neither executed nor answered.
  void SetDropPolls(bool drop);
  // The next n complete poll commands are not answered.
  void DropNextPolls(uint32_t n);
  // Every poll response (and CoS message) leaves `delay` after the poll, on the injected clock.
  void SetResponseDelay(Duration delay);
  // Fragmented responses lose their first middle fragment (or the last, if there is none).
  void SetCorruptFragments(bool corrupt);
  // Poll responses carry produced_size + delta bytes (delta != 0: wrong response length).
  void SetResponseLengthDelta(int delta);
  // Bus-off: stop transmitting, drop all connections, latch 0x8148; recovery per D-16.
  void GoBusOff();
  // CAN controller reset after bus-off: new duplicate MAC check, application state kept.
  void RecoverBusOff();
  // Lonely node: the duplicate MAC check never completes (no acknowledge), 0x8143 latched.
  void SetLonelyNode(bool lonely);
  // The next duplicate MAC check is answered (as if a node with the same MAC existed): the
  // drive restarts its check and ends communication faulted with 0x8101 (TC-10).
  void InjectDuplicateMac();
  // CAN error states 0x8140-0x8145 and 0x8148, or any §8.6 code, latched as a coded error
  // (→ ERROR Pending, D-7). InvalidArgument for a code §8.6 does not list.
  absl::Status RaiseCodedError(uint16_t code);
  // Power cycle: device and stack back to power-up (volatile parameters lost, D-29).
  void PowerCycle();

  // Runs `fn` on the device (motor faults, warnings, inputs, disturbances: see device.h) or the
  // stack under the server lock, after advancing to clock.Now().
  void WithDevice(const std::function<void(LinMotDnDevice&)>& fn);
  void WithStack(const std::function<void(DnStack&)>& fn);

 private:
  struct Pending {
    TimePoint due;
    dn::Frame frame;
  };

  LinMotDnServer(const DnSimOptions& options, const Clock& clock,
                 std::unique_ptr<transport::CanChannel> channel,
                 std::unique_ptr<LinMotDnDevice> device, std::unique_ptr<DnStack> stack);
  void Run();
  void AdvanceLocked();
  void HandleFrameLocked(const transport::CanFrame& frame);
  void SendLocked(const std::vector<OutFrame>& frames);
  void FlushDueLocked();
  void RecordLocked(bool transmitted, const dn::Frame& frame);

  const DnSimOptions options_;
  const Clock& clock_;
  const uint8_t mac_id_;
  std::unique_ptr<transport::CanChannel> channel_;

  mutable std::mutex mu_;
  std::unique_ptr<LinMotDnDevice> device_;  // guarded by mu_
  std::unique_ptr<DnStack> stack_;          // guarded by mu_
  TimePoint last_advance_;                  // guarded by mu_
  ServerCounters counters_;                 // guarded by mu_
  std::deque<Pending> pending_;             // guarded by mu_, sorted by due
  std::deque<FrameRecord> frames_;          // guarded by mu_
  size_t max_frames_ = 4096;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::linmot_devicenet
