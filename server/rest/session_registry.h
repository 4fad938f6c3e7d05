// What RestServer::Stop needs of every live connection (HTTP or WebSocket): a registry of weak
// references it can close from the stopping thread once the I/O threads are joined.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace drivegw::rest {

class SessionBase : public std::enable_shared_from_this<SessionBase> {
 public:
  virtual ~SessionBase() = default;
  // Closes the connection at once; only called when no I/O thread runs.
  virtual void CloseNow() = 0;
};

class SessionRegistry {
 public:
  void Add(SessionBase* s, std::weak_ptr<SessionBase> weak) {
    std::lock_guard lock(mu_);
    sessions_.emplace(s, std::move(weak));
  }
  void Remove(SessionBase* s) {
    std::lock_guard lock(mu_);
    sessions_.erase(s);
  }
  std::vector<std::shared_ptr<SessionBase>> Live() {
    std::vector<std::shared_ptr<SessionBase>> out;
    std::lock_guard lock(mu_);
    for (auto& [ptr, weak] : sessions_) {
      if (auto s = weak.lock()) out.push_back(std::move(s));
    }
    return out;
  }

 private:
  std::mutex mu_;
  std::map<SessionBase*, std::weak_ptr<SessionBase>> sessions_;
};

}  // namespace drivegw::rest
