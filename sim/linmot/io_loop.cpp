// SharedIoLoop: epoll over every simulated drive's socket, handlers serialised on one thread.
#include "sim/linmot/io_loop.h"

#include <sys/epoll.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::linmot {
namespace {

constexpr int kPendingPollMs = 1;  // delayed replies: the old per-server loop polled every 1 ms
constexpr int kIdlePollMs = 50;    // nothing pending: only readiness matters
constexpr int kMaxEvents = 64;

}  // namespace

SharedIoLoop& SharedIoLoop::Instance() {
  // Never destroyed: servers may be stopped from static destructors after main returns.
  static SharedIoLoop* loop = new SharedIoLoop();
  return *loop;
}

SharedIoLoop::SharedIoLoop() : epoll_fd_(::epoll_create1(EPOLL_CLOEXEC)) {
  thread_ = std::thread([this] { Run(); });
  thread_.detach();  // lives as long as the process
}

absl::Status SharedIoLoop::Add(int fd, Handler handler) {
  std::lock_guard lock(mu_);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.fd = fd;
  if (epoll_fd_ < 0 || ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0) {
    return absl::InternalError(absl::StrCat("linmot sim io loop: epoll_ctl add fd ", fd, ": ",
                                            std::strerror(epoll_fd_ < 0 ? EBADF : errno)));
  }
  entries_[fd] = Entry{std::move(handler), false};
  return absl::OkStatus();
}

void SharedIoLoop::Remove(int fd) {
  std::lock_guard lock(mu_);
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
  entries_.erase(fd);
}

void SharedIoLoop::Run() {
  std::array<epoll_event, kMaxEvents> events{};
  bool any_pending = false;
  for (;;) {
    const int n = ::epoll_wait(epoll_fd_, events.data(), kMaxEvents,
                               any_pending ? kPendingPollMs : kIdlePollMs);
    if (n < 0 && errno != EINTR) return;
    std::lock_guard lock(mu_);
    for (int i = 0; i < n; ++i) {
      auto it = entries_.find(events[static_cast<size_t>(i)].data.fd);
      if (it == entries_.end()) continue;  // removed after epoll_wait returned
      it->second.pending = it->second.handler();
    }
    // Handlers with delayed replies run on every turn (at least every kPendingPollMs).
    any_pending = false;
    for (auto& [fd, e] : entries_) {
      if (!e.pending) continue;
      e.pending = e.handler();
      any_pending = any_pending || e.pending;
    }
  }
}

}  // namespace drivegw::sim::linmot
