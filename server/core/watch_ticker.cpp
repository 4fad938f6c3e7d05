// WatchTicker: period groups on a few timer-wheel threads; clients tick outside the wheel's lock.
#include "server/core/watch_ticker.h"

#include <pthread.h>

#include <algorithm>
#include <utility>

namespace drivegw::server {

class WatchTicker::Wheel {
 public:
  Wheel() : thread_([this] { Run(); }) {}
  ~Wheel() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

  void Add(Clock::duration period, std::shared_ptr<Client> client) {
    {
      std::lock_guard lock(mu_);
      auto [it, fresh] = groups_.try_emplace(period);
      if (fresh) it->second.due = Clock::now() + period;
      it->second.clients.push_back(std::move(client));
      ++count_;
    }
    cv_.notify_all();
  }

  size_t clients() const {
    std::lock_guard lock(mu_);
    return count_;
  }

 private:
  struct Group {
    Clock::time_point due;
    std::vector<std::shared_ptr<Client>> clients;
  };

  void Run() {
    // Named so that per-thread CPU (/proc/<pid>/task/*/comm, top -H, perf) tells the watch ticks
    // from gRPC's threads (P5 CPU split, decision 1372).
    ::pthread_setname_np(::pthread_self(), "watch_tick");
    std::vector<std::shared_ptr<Client>> ticking;
    std::unique_lock lock(mu_);
    while (!stop_) {
      auto it = std::min_element(groups_.begin(), groups_.end(), [](const auto& a, const auto& b) {
        return a.second.due < b.second.due;
      });
      if (it == groups_.end()) {
        cv_.wait(lock);
        continue;
      }
      const Clock::duration period = it->first;
      if (Clock::now() < it->second.due) {
        // A new group may be due earlier: Add notifies.
        cv_.wait_until(lock, it->second.due);
        continue;
      }
      // Tick outside the lock so that Add (a new stream) never waits for a whole tick; clients
      // added meanwhile land in the group's (now empty) list and are merged back below.
      ticking.swap(it->second.clients);
      lock.unlock();
      const size_t ticked = ticking.size();
      size_t kept = 0;
      for (auto& c : ticking) {
        if (c->Tick()) ticking[kept++] = std::move(c);
      }
      ticking.resize(kept);
      lock.lock();
      Group& g = groups_[period];
      count_ -= ticked - kept;  // the dropped ones; clients added meanwhile are counted by Add
      ticking.insert(ticking.end(), std::make_move_iterator(g.clients.begin()),
                     std::make_move_iterator(g.clients.end()));
      g.clients.swap(ticking);
      ticking.clear();
      // The next tick is a period after this one was due; a wheel that fell behind ticks once
      // now rather than in a burst (latest wins, decision 504 item 5).
      g.due += period;
      if (const auto now = Clock::now(); g.due < now) g.due = now;
      if (g.clients.empty()) groups_.erase(period);
    }
  }

  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  size_t count_ = 0;
  std::map<Clock::duration, Group> groups_;  // by period
  std::thread thread_;                       // last: starts after the members it uses
};

WatchTicker::WatchTicker(size_t threads) {
  for (size_t i = 0; i < std::max<size_t>(threads, 1); ++i)
    wheels_.push_back(std::make_unique<Wheel>());
}

WatchTicker::~WatchTicker() = default;

void WatchTicker::Add(Clock::duration period, std::shared_ptr<Client> client) {
  size_t wheel = 0;
  {
    std::lock_guard lock(mu_);
    wheel = next_++ % wheels_.size();
  }
  wheels_[wheel]->Add(period, std::move(client));
}

size_t WatchTicker::clients() const {
  size_t n = 0;
  for (const auto& w : wheels_) n += w->clients();
  return n;
}

size_t WatchTicker::DefaultThreads() {
  return std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 4);
}

}  // namespace drivegw::server
