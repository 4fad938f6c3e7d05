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
    return {Action::kFinish, output_, nullptr,
            cancelled_ ? absl::CancelledError("WatchDrives: the client cancelled or went away")
                       : absl::OkStatus()};
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
      step.output->Finish(step.status);
      break;
    case Action::kNone:
      break;
  }
}

void WatchStream::PollLocked() {
  if (cancelled_ || source_->Ended()) return;
  polled_.clear();
  source_->Next(polled_);
  for (auto& s : polled_) pending_.push_back(std::move(s));
}

bool WatchStream::Tick() noexcept {
  Step step;
  {
    std::lock_guard lock(mu_);
    if (finished_) return false;
    if (writing_ || !pending_.empty()) {
      // The consumer is still busy with the last poll: this tick is owed and made up by one poll
      // when the write completes (the latest snapshot then, never a backlog), as the producer
      // thread per stream did when a write outlasted its period.
      missed_ = true;
    } else {
      PollLocked();
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
    if (missed_ && pending_.empty()) {
      missed_ = false;
      PollLocked();
    }
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
