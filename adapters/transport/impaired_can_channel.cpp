// ImpairedCanChannel: seeded per-frame faults on a CanChannel, delays from one helper thread.
#include "adapters/transport/impaired_can_channel.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {

using Clock = std::chrono::steady_clock;

absl::StatusOr<std::unique_ptr<ImpairedCanChannel>> ImpairedCanChannel::Wrap(
    std::unique_ptr<CanChannel> inner, const Impairment& send, const Impairment& receive) {
  if (inner == nullptr) return absl::InvalidArgumentError("impaired can channel: no channel");
  if (absl::Status s = ImpairedLink::Validate(send); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("send ", s.message()));
  }
  if (absl::Status s = ImpairedLink::Validate(receive); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("receive ", s.message()));
  }
  return std::unique_ptr<ImpairedCanChannel>(
      new ImpairedCanChannel(std::move(inner), send, receive));
}

ImpairedCanChannel::ImpairedCanChannel(std::unique_ptr<CanChannel> inner, const Impairment& send,
                                       const Impairment& receive)
    : inner_(std::move(inner)), send_link_(send), receive_link_(receive) {
  delay_thread_ = std::thread([this] { DelayLoop(); });
}

ImpairedCanChannel::~ImpairedCanChannel() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  delay_thread_.join();
}

void ImpairedCanChannel::ScheduleLocked(std::chrono::nanoseconds delay, Direction direction,
                                        const CanFrame& frame, std::vector<CanFrame>& out) {
  if (delay.count() <= 0) {
    out.push_back(frame);
    return;
  }
  Delayed d{Clock::now() + delay, direction, frame};
  auto it = std::upper_bound(delayed_.begin(), delayed_.end(), d.due,
                             [](Clock::time_point t, const Delayed& q) { return t < q.due; });
  delayed_.insert(it, std::move(d));
  cv_.notify_all();
}

void ImpairedCanChannel::ApplyLocked(ImpairedLink& link, std::optional<CanFrame>& held,
                                     Direction direction, const CanFrame& frame,
                                     std::vector<CanFrame>& out) {
  const ImpairmentDecision d = link.Decide();
  if (d.drop) return;
  CanFrame copy = frame;
  if (d.corrupt && !copy.rtr) {
    copy.dlc = static_cast<uint8_t>(TruncatedLength(copy.dlc, d.corrupt_bits));
    // The bytes beyond the new DLC are not on the wire.
    std::fill(copy.data.begin() + copy.dlc, copy.data.end(), 0);
  }
  if (d.reorder && !held) {
    held = copy;
    return;
  }
  ScheduleLocked(d.delay, direction, copy, out);
  if (d.duplicate) ScheduleLocked(d.duplicate_delay, direction, copy, out);
  if (held) {  // explicit reorder: the held frame follows the one after it
    ScheduleLocked(d.delay, direction, *held, out);
    held.reset();
  }
}

absl::Status ImpairedCanChannel::Send(const CanFrame& frame) {
  if (absl::Status s = ValidateCanFrame(frame); !s.ok()) return s;
  std::vector<CanFrame> now;
  {
    std::lock_guard lock(mu_);
    ApplyLocked(send_link_, held_send_, Direction::kSend, frame, now);
  }
  absl::Status result = absl::OkStatus();
  for (const CanFrame& f : now) {
    if (absl::Status s = inner_->Send(f); !s.ok() && result.ok()) result = s;
  }
  return result;
}

absl::StatusOr<std::optional<CanFrame>> ImpairedCanChannel::Receive(
    std::chrono::nanoseconds timeout) {
  const Clock::time_point deadline = Clock::now() + std::max(timeout, std::chrono::nanoseconds{0});
  for (;;) {
    {
      std::lock_guard lock(mu_);
      if (!ready_.empty()) {
        CanFrame f = ready_.front();
        ready_.pop_front();
        return f;
      }
      if (woken_) {
        woken_ = false;
        return std::nullopt;
      }
    }
    const auto left = std::max(deadline - Clock::now(), Clock::duration::zero());
    absl::StatusOr<std::optional<CanFrame>> got =
        inner_->Receive(std::chrono::duration_cast<std::chrono::nanoseconds>(left));
    if (!got.ok()) return got.status();
    if (got->has_value()) {
      std::vector<CanFrame> now;
      std::lock_guard lock(mu_);
      ApplyLocked(receive_link_, held_receive_, Direction::kReceive, **got, now);
      ready_.insert(ready_.end(), now.begin(), now.end());
      continue;
    }
    std::lock_guard lock(mu_);
    if (ready_.empty() && !woken_ && Clock::now() >= deadline) return std::nullopt;
  }
}

void ImpairedCanChannel::Wake() {
  {
    std::lock_guard lock(mu_);
    woken_ = true;
  }
  inner_->Wake();
}

absl::Status ImpairedCanChannel::SetFilters(std::span<const CanFilter> filters) {
  return inner_->SetFilters(filters);
}

absl::Status ImpairedCanChannel::SetImpairment(const Impairment& send, const Impairment& receive) {
  if (absl::Status s = ImpairedLink::Validate(send); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("send ", s.message()));
  }
  if (absl::Status s = ImpairedLink::Validate(receive); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("receive ", s.message()));
  }
  std::optional<CanFrame> release;
  {
    std::lock_guard lock(mu_);
    send_link_ = ImpairedLink(send);
    receive_link_ = ImpairedLink(receive);
    release.swap(held_send_);
    if (held_receive_) {
      ready_.push_back(*held_receive_);
      held_receive_.reset();
    }
  }
  if (release) return inner_->Send(*release);
  return absl::OkStatus();
}

ImpairedCanCounters ImpairedCanChannel::impaired_counters() const {
  std::lock_guard lock(mu_);
  return {send_link_.counters(), receive_link_.counters()};
}

void ImpairedCanChannel::DelayLoop() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    if (delayed_.empty()) {
      cv_.wait(lock);
      continue;
    }
    if (Clock::now() < delayed_.front().due) {
      cv_.wait_until(lock, delayed_.front().due);
      continue;
    }
    Delayed d = std::move(delayed_.front());
    delayed_.pop_front();
    if (d.direction == Direction::kReceive) {
      ready_.push_back(d.frame);
      lock.unlock();
      inner_->Wake();  // a Receive blocked in the inner channel picks it up
    } else {
      lock.unlock();
      (void)inner_->Send(d.frame);  // a late frame the bus refuses is lost like any other
    }
    lock.lock();
  }
}

}  // namespace drivegw::transport
