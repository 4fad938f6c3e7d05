// LinMotServer: one simulated LinMot drive answering LinUDP V2 on a real UDP socket, with its
// physics advanced to an injected clock on every datagram (never by sleeping), plus fault hooks.
#pragma once

#include <array>
#include <atomic>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/transport/endpoint.h"
#include "adapters/transport/impaired_link.h"
#include "adapters/transport/udp_socket.h"
#include "sim/linmot/options.h"
#include "sim/linmot/snapshot.h"

namespace drivegw::sim::linmot {

class LinMotDevice;

// Thread model: the process-wide SharedIoLoop thread (io_loop.h) serves the socket of every
// server; every public method is thread-safe and serialised with it by one mutex. The device is
// advanced to clock.Now() in fixed ticks (D-23) whenever a datagram arrives and whenever a test
// hook or Snapshot() is called.
class LinMotServer {
 public:
  // Validates the options, creates the device, binds `options.bind` and starts the thread.
  // `clock` must outlive the server (ManualClock in tests, SteadyClock::Instance() otherwise).
  static absl::StatusOr<std::unique_ptr<LinMotServer>> Start(const SimOptions& options,
                                                             const Clock& clock);
  ~LinMotServer();  // Stop()
  LinMotServer(const LinMotServer&) = delete;
  LinMotServer& operator=(const LinMotServer&) = delete;

  // Bound UDP port (the ephemeral one when options.bind.port was 0) and full endpoint.
  uint16_t port() const { return local_.port; }
  transport::Endpoint endpoint() const { return local_; }
  const SimOptions& options() const { return options_; }

  // Stops the thread and closes the socket; idempotent.
  void Stop();

  // ---- observation ----
  SimSnapshot Snapshot();
  ServerCounters counters() const;

  // ---- fault injection (all take effect at clock.Now()) ----
  // Raises a §10 error code with the D-34 reaction (quick stop via 14 if moving, else 4).
  // InvalidArgument for 0 or a code the §10 table does not list (D-33).
  absl::Status RaiseError(uint16_t code);
  // Warn word bits forced on (OR-ed with the computed ones), e.g. WarnWord::kMotorSupplyVoltageLow.
  void SetInjectedWarnings(uint16_t warn_bits);
  // Freezes the slider where it is (collision): the position lag grows until 000Bh/000Ch.
  void SetMotorBlocked(bool blocked);
  // Seeded drop/delay/duplicate/reorder/corrupt of replies (linmot-linudp.md A-07 tests).
  // Validated. A corrupt reply is sent truncated (UDP's checksum rejects flipped bits before
  // the gateway sees them; decision 1421).
  absl::Status SetImpairment(const transport::Impairment& impairment);
  // The same for requests from the master, applied before they reach the device: drop,
  // duplicate (handled twice), reorder (handled after the next one), corrupt (truncated).
  // Delays are not applied to requests (the reply delay covers the round trip). Validated.
  absl::Status SetRequestImpairment(const transport::Impairment& impairment);
  // Extra delay before every reply, measured on the injected clock.
  void SetReplyDelay(Duration delay);
  // Link loss: while false, datagrams are read and counted but never answered and the device is
  // not touched (physics still advances with the clock).
  void SetAnswering(bool answering);

  // Runs `fn` on the device under the server lock after advancing it to clock.Now(); for tests
  // that need a device hook the server does not wrap (parameters, error log, ...).
  void WithDevice(const std::function<void(LinMotDevice&)>& fn);

 private:
  struct PendingReply {
    TimePoint due;
    transport::Endpoint to;
    std::vector<uint8_t> bytes;
  };

  LinMotServer(const SimOptions& options, const Clock& clock, transport::UdpSocket socket,
               std::unique_ptr<LinMotDevice> device);
  // SharedIoLoop handler: takes the queued datagrams (one recvmmsg), answers them, sends the
  // delayed replies that are due. True while delayed replies wait.
  bool OnReadable();
  void AdvanceLocked();
  void HandleDatagramLocked(const transport::Endpoint& from, std::span<const uint8_t> bytes);
  // Applies the request impairment, then HandleDatagramLocked.
  void ImpairRequestLocked(const transport::Endpoint& from, std::span<const uint8_t> bytes);
  void QueueReplyLocked(const transport::Endpoint& to, std::vector<uint8_t> bytes);
  void FlushDueLocked();

  const SimOptions options_;
  const Clock& clock_;
  transport::UdpSocket socket_;
  transport::Endpoint local_;

  mutable std::mutex mu_;
  std::unique_ptr<LinMotDevice> device_;                       // guarded by mu_
  TimePoint last_advance_;                                     // guarded by mu_
  ServerCounters counters_;                                    // guarded by mu_
  std::optional<transport::ImpairedLink> impairment_;          // guarded by mu_
  std::optional<transport::ImpairedLink> request_impairment_;  // guarded by mu_
  struct HeldRequest {
    transport::Endpoint from;
    std::vector<uint8_t> bytes;
  };
  std::optional<HeldRequest> held_request_;  // guarded by mu_ (request reorder)
  struct HeldReply {
    transport::Endpoint to;
    std::vector<uint8_t> bytes;
  };
  std::optional<HeldReply> held_reply_;        // guarded by mu_ (reply reorder)
  Duration reply_delay_{0};                    // guarded by mu_
  bool answering_ = true;                      // guarded by mu_
  std::optional<uint32_t> latched_master_ip_;  // guarded by mu_ (A-15 single master)
  std::deque<PendingReply> pending_;           // guarded by mu_, sorted by due

  static constexpr size_t kReceiveSlots = 8;
  std::array<std::array<uint8_t, 512>, kReceiveSlots> receive_buffers_{};  // guarded by mu_
  std::array<transport::DatagramSlot, kReceiveSlots> receive_slots_{};     // guarded by mu_

  std::atomic<bool> running_{false};
};

}  // namespace drivegw::sim::linmot
