// ImpairedCanChannel: a CanChannel decorator that applies seeded ImpairedLink decisions to the
// frames one node sends and receives (drop, duplicate, delay, reorder, corrupt). One impairment
// description and one decision source for every CAN family (DeviceNet, CANopen/STOBER, Trinamic
// CAN); decision 1421 says what each fault models on CAN.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "adapters/transport/can_channel.h"
#include "adapters/transport/impaired_link.h"

namespace drivegw::transport {

struct ImpairedCanCounters {
  ImpairedLinkCounters send;     // decisions on frames this node sent
  ImpairedLinkCounters receive;  // decisions on frames this node received
};

// Wrap a simulator's channel to impair both directions of the link between it and the gateway
// (its receive side is the gateway's requests, its send side the replies), or a gateway's
// channel on a test bench. Frames are impaired per frame:
//  - drop: Send returns OK and the frame never reaches the bus (a frame lost at the receiver;
//    the sender's controller cannot tell on a bus where other nodes acknowledge); Receive skips it.
//  - duplicate: a second copy after duplicate_delay.
//  - delay: the frame goes out (or is returned) after `delay`, from the decorator's own thread.
//  - reorder: held back and released right after the next frame in the same direction.
//  - corrupt: the DLC is cut short (TruncatedLength) on a copy: CAN's CRC turns bit flips into
//    error frames, so what survives to a codec is a frame of the wrong length (decision 1421).
class ImpairedCanChannel final : public CanChannel {
 public:
  // InvalidArgument naming the field when either impairment is invalid (ImpairedLink::Validate).
  static absl::StatusOr<std::unique_ptr<ImpairedCanChannel>> Wrap(std::unique_ptr<CanChannel> inner,
                                                                  const Impairment& send,
                                                                  const Impairment& receive);
  ~ImpairedCanChannel() override;

  absl::Status Send(const CanFrame& frame) override;
  absl::StatusOr<std::optional<CanFrame>> Receive(std::chrono::nanoseconds timeout) override;
  void Wake() override;
  absl::Status SetFilters(std::span<const CanFilter> filters) override;
  CanBusState state() const override { return inner_->state(); }
  CanCounters counters() const override { return inner_->counters(); }
  std::string name() const override { return inner_->name(); }

  // Replaces both impairments (tests stop the loss); decisions restart from the new seeds and a
  // held (reordered) frame is released. Validated like Wrap.
  absl::Status SetImpairment(const Impairment& send, const Impairment& receive);
  ImpairedCanCounters impaired_counters() const;

 private:
  enum class Direction { kSend, kReceive };
  struct Delayed {
    std::chrono::steady_clock::time_point due;
    Direction direction;
    CanFrame frame;
  };

  ImpairedCanChannel(std::unique_ptr<CanChannel> inner, const Impairment& send,
                     const Impairment& receive);
  // Applies one decision; frames due now are appended to `out` in order, later ones go to the
  // delay thread. Called with mu_ held.
  void ApplyLocked(ImpairedLink& link, std::optional<CanFrame>& held, Direction direction,
                   const CanFrame& frame, std::vector<CanFrame>& out);
  void ScheduleLocked(std::chrono::nanoseconds delay, Direction direction, const CanFrame& frame,
                      std::vector<CanFrame>& out);
  void DelayLoop();

  const std::unique_ptr<CanChannel> inner_;
  mutable std::mutex mu_;
  std::condition_variable cv_;            // delay thread: new delayed frame or stop
  ImpairedLink send_link_;                // guarded by mu_
  ImpairedLink receive_link_;             // guarded by mu_
  std::optional<CanFrame> held_send_;     // guarded by mu_ (reorder)
  std::optional<CanFrame> held_receive_;  // guarded by mu_ (reorder)
  std::deque<CanFrame> ready_;            // guarded by mu_: received frames to return
  std::deque<Delayed> delayed_;           // guarded by mu_, sorted by due
  bool woken_ = false;                    // guarded by mu_
  bool stop_ = false;                     // guarded by mu_
  std::thread delay_thread_;
};

}  // namespace drivegw::transport
