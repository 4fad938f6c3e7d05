// TrinamicServer: one simulated SIXpack/QUADpack on a pseudo-terminal; the controller is advanced
// to an injected clock on every byte burst (never by sleeping), with packet timeout and faults.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/transport/pty.h"
#include "sim/trinamic/controller.h"
#include "sim/trinamic/options.h"

namespace drivegw::sim::trinamic {

struct ServerCounters {
  uint64_t bytes_in = 0;
  uint64_t words = 0;             // complete 9-byte words decoded
  uint64_t words_dropped = 0;     // complete words the codec refused (unknown opcode, G-06)
  uint64_t partial_timeouts = 0;  // partial words discarded by the packet timeout (L279)
  uint64_t replies = 0;
  uint64_t resets = 0;  // injected power losses
};

// Thread model: one thread owns the pty loop; public methods are thread-safe and serialised with
// it by one mutex. Replies are written at once: a pty enforces no character timing, so the `$40`
// switchover delay is not reproduced here (decision 1037).
class TrinamicServer {
 public:
  // `clock` must outlive the server (ManualClock in tests, SteadyClock::Instance() otherwise).
  static absl::StatusOr<std::unique_ptr<TrinamicServer>> Start(const ServerOptions& options,
                                                               const Clock& clock);
  ~TrinamicServer();
  TrinamicServer(const TrinamicServer&) = delete;
  TrinamicServer& operator=(const TrinamicServer&) = delete;

  const std::string& slave_path() const { return pty_.slave_path(); }
  void Stop();  // idempotent
  ServerCounters counters() const;

  // ---- fault injection and introspection (take effect at clock.Now()) ----
  void SetSilent(bool silent);
  void LoseSteps(int motor, int64_t steps);
  void SetStuckSwitch(int motor, std::optional<bool> level);
  // Runs `fn` on the controller under the lock after advancing it to clock.Now().
  void WithController(const std::function<void(Controller&)>& fn);

 private:
  TrinamicServer(const ServerOptions& options, const Clock& clock, transport::PseudoTerminal pty,
                 Controller controller);
  void Run();
  void AdvanceLocked();
  void ReceiveLocked(const std::vector<uint8_t>& bytes);
  void SendLocked(const std::vector<uint8_t>& bytes);

  ServerOptions options_;
  const Clock& clock_;
  transport::PseudoTerminal pty_;
  mutable std::mutex mu_;
  Controller controller_;
  TimePoint start_;
  TimePoint advanced_to_;
  std::vector<uint8_t> partial_;
  TimePoint partial_since_{};
  bool reset_done_ = false;
  ServerCounters counters_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::trinamic
