// WatchStream: the per-stream state machine between the shared ticker and the transport.
#include "server/core/watch_stream.h"

#include <utility>

namespace drivegw::server {

WatchStream::WatchStream(std::unique_ptr<WatchSource> source, Output* output)
    : source_(std::move(source)), output_(output) {}

WatchStream::Step WatchStream::NextLocked() {
  if (finished_ || writing_ || output_ == nullptr) return {};
  if (cancelled_ || source_->Ended()) {
    finished_ = true;
    return {Action::kFinish, output_, nullptr};
  }
  if (pending_.empty()) return {};
  current_ = std::move(pending_.front());
  pending_.pop_front();
  writing_ = true;
  return {Action::kWrite, output_, current_};
}

void WatchStream::Run(const Step& step) noexcept {
  // Outside the lock: gRPC may run OnDone (-> Detach) inline from Finish.
  switch (step.action) {
    case Action::kWrite:
      step.output->StartWrite(step.message);
      break;
    case Action::kFinish:
      step.output->Finish(absl::OkStatus());
      break;
    case Action::kNone:
      break;
  }
}

bool WatchStream::Tick() noexcept {
  Step step;
  {
    std::lock_guard lock(mu_);
    if (finished_) return false;
    // A write still in flight or snapshots of the last poll still queued: this consumer is slow;
    // skip it this tick, the next poll sends the latest snapshot instead of a backlog.
    if (!writing_ && pending_.empty() && !cancelled_ && !source_->Ended()) {
      polled_.clear();
      source_->Next(polled_);
      for (auto& s : polled_) pending_.push_back(std::move(s));
    }
    step = NextLocked();
  }
  Run(step);
  return step.action != Action::kFinish;
}

void WatchStream::WriteDone(bool ok) noexcept {
  Step step;
  {
    std::lock_guard lock(mu_);
    writing_ = false;
    current_.reset();
    if (!ok) cancelled_ = true;
    step = NextLocked();
  }
  Run(step);
}

void WatchStream::Cancel() noexcept {
  Step step;
  {
    std::lock_guard lock(mu_);
    cancelled_ = true;
    step = NextLocked();
  }
  Run(step);
}

void WatchStream::Detach() noexcept {
  std::lock_guard lock(mu_);
  finished_ = true;
  writing_ = false;
  output_ = nullptr;
  pending_.clear();
}

}  // namespace drivegw::server
