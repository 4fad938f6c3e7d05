// One watch stream served by the shared WatchTicker (issue 10, P5; decision 1341): at each tick it
// asks its source for the changed snapshots and starts a write only when the previous one has
// completed — a busy consumer is not polled, never queued; the tick it missed is made up by one
// poll when its write completes, which yields the latest snapshot (latest wins, decision 504
// item 5). The transport (gRPC reactor, test fake) is the
// Output; nothing here blocks.
#pragma once

#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/status/status.h"
#include "drivegw/v1/drive.pb.h"
#include "server/core/watch_ticker.h"

namespace drivegw::server {

using SharedDriveStatus = std::shared_ptr<const v1::DriveStatus>;

// Where a stream's messages come from: non-blocking, called from ticker threads.
class WatchSource {
 public:
  virtual ~WatchSource() = default;
  // Appends the snapshots to send now (changed ones only, at most one per drive).
  virtual void Next(std::vector<SharedDriveStatus>& out) = 0;
  // True once the source ends every stream (server shutdown): the stream finishes OK (unless
  // the client had already gone: CANCELLED).
  virtual bool Ended() const noexcept = 0;
};

class WatchStream final : public WatchTicker::Client {
 public:
  // The transport. Both calls are made without the stream's lock held, so either may complete
  // (WriteDone, Detach) inline.
  class Output {
   public:
    virtual ~Output() = default;
    // Starts writing `s` (kept alive by the stream until WriteDone). One write at a time.
    virtual void StartWrite(const SharedDriveStatus& s) noexcept = 0;
    // Ends the stream; called once, never while a write is in flight.
    virtual void Finish(const absl::Status& s) noexcept = 0;
  };

  WatchStream(std::unique_ptr<WatchSource> source, Output* output);

  // Ticker: poll the source and start a write if none is in flight. False once finished.
  bool Tick() noexcept override;
  // Output: the write started last has completed (`ok` false: the client is gone).
  void WriteDone(bool ok) noexcept;
  // Output: the client cancelled or the deadline passed; finishes (CANCELLED, so per-RPC metrics
  // tell an abandoned watch from one the server ended) once no write is in flight.
  void Cancel() noexcept;
  // Output: the transport is gone; the stream never calls it again.
  void Detach() noexcept;

 private:
  enum class Action { kNone, kWrite, kFinish };
  struct Step {
    Action action = Action::kNone;
    Output* output = nullptr;  // read under mu_: Detach clears it
    SharedDriveStatus message;
    absl::Status status;  // kFinish: how the stream ends
  };
  // Under mu_: what to do next given the state; marks the write or the finish as started.
  Step NextLocked();
  // Under mu_: asks the source for the snapshots to send now (unless the stream is ending).
  void PollLocked();
  static void Run(const Step& step) noexcept;

  std::mutex mu_;
  std::unique_ptr<WatchSource> source_;
  Output* output_;
  std::vector<SharedDriveStatus> polled_;  // reused by Next
  std::deque<SharedDriveStatus> pending_;  // one tick's snapshots still to write (one per drive)
  SharedDriveStatus current_;              // in flight
  bool writing_ = false;
  bool missed_ = false;  // a tick came while busy: poll once when the write completes
  bool cancelled_ = false;
  bool finished_ = false;
};

}  // namespace drivegw::server
