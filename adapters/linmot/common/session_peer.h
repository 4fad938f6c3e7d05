#pragma once

// Session-peer plumbing shared by the LinMot drives (LinUDP and DeviceNet): both hold a
// shared_ptr to their bus session and a peer id under the drive's state mutex. The session is
// always called outside that mutex (lock order: session lock -> drive mutex), so every helper
// copies or moves the pointer under the lock and calls the session after releasing it.

#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>

namespace drivegw::linmot {

// Detaches the drive from its session: under `mu` moves the session out, takes the peer id and
// clears `active`; then unregisters outside the lock (no peer callback runs after Unregister
// returns). Returns the session so that the caller drops the last reference — which may close
// the bus — outside its mutex too.
template <typename Mutex, typename Session, typename Id>
std::shared_ptr<Session> DetachSessionPeer(Mutex& mu, std::shared_ptr<Session>& session_slot,
                                           const Id& peer_id, bool& active) {
  std::shared_ptr<Session> session;
  Id id{};
  {
    std::lock_guard lock(mu);
    session = std::move(session_slot);
    id = peer_id;
    active = false;
  }
  if (session) session->Unregister(id);
  return session;
}

// The session's per-peer counters for `peer_id`, or nullopt while not registered.
template <typename Mutex, typename Session, typename Id>
auto SessionPeerCounters(Mutex& mu, const std::shared_ptr<Session>& session_slot, const Id& peer_id)
    -> decltype(session_slot->peer_counters(peer_id)) {
  std::shared_ptr<Session> session;
  Id id{};
  {
    std::lock_guard lock(mu);
    session = session_slot;
    id = peer_id;
  }
  if (!session) return std::nullopt;
  return session->peer_counters(id);
}

// The session-wide counters, or nullopt while not registered.
template <typename Mutex, typename Session>
auto SessionCountersOf(Mutex& mu, const std::shared_ptr<Session>& session_slot)
    -> std::optional<decltype(session_slot->counters())> {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(mu);
    session = session_slot;
  }
  if (!session) return std::nullopt;
  return session->counters();
}

// The drives' wait loop under the drive mutex: checked in this order on every wake-up —
// deactivated, condition reached, link lost, deadline passed — so that a drive deactivated while
// the condition also holds reports inactive. `Wait` is the drive's own enum with kReached,
// kDeadline, kOffline and kInactive.
template <typename Wait, typename Lock, typename Clock, typename TimePoint, typename Active,
          typename Reached, typename Offline>
Wait WaitPeerLocked(std::condition_variable& cv, Lock& lock, const Clock& clock, TimePoint deadline,
                    Active active, Reached reached, Offline offline) {
  for (;;) {
    if (!active()) return Wait::kInactive;
    if (reached()) return Wait::kReached;
    if (offline()) return Wait::kOffline;
    const auto now = clock.Now();
    if (now >= deadline) return Wait::kDeadline;
    cv.wait_for(lock, deadline - now);
  }
}

}  // namespace drivegw::linmot
