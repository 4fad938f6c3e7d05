// Bare building blocks of an acknowledged drive command, with no gateway code (issue 10 P1,
// decision 1433): the bare gRPC echo service with an optional step before its reply, a LinUDP
// round trip done inline or handed over to an I/O thread, and one durable audit-sized SQLite
// insert. move_ack_bench composes them into the floor of any design that acknowledges a move.
#pragma once

#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/grpcpp.h>
#include <sqlite3.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "adapters/linmot/linudp/codec.h"
#include "adapters/transport/udp_socket.h"

namespace drivegw::bench {

[[noreturn]] inline void Die(const std::string& what) {
  std::fprintf(stderr, "%s\n", what.c_str());
  std::exit(1);
}

// Bare gRPC unary echo: a callback generic service returning the request bytes. `before_reply`
// (if set) runs on gRPC's callback thread between reading the request and writing the reply,
// where a gateway handler does its work.
class EchoService final : public grpc::CallbackGenericService {
 public:
  explicit EchoService(std::function<void()> before_reply = {})
      : before_reply_(std::move(before_reply)) {}

 private:
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext*) override {
    class Reactor final : public grpc::ServerGenericBidiReactor {
     public:
      explicit Reactor(const std::function<void()>& before_reply) : before_reply_(before_reply) {
        StartRead(&buf_);
      }
      void OnReadDone(bool ok) override {
        if (!ok) {
          Finish(grpc::Status::OK);
          return;
        }
        if (before_reply_) before_reply_();
        StartWrite(&buf_);
      }
      void OnWriteDone(bool) override { Finish(grpc::Status::OK); }
      void OnDone() override { delete this; }

     private:
      const std::function<void()>& before_reply_;
      grpc::ByteBuffer buf_;
    };
    return new Reactor(before_reply_);
  }

  std::function<void()> before_reply_;
};

// The status poll the UDP baseline sends (linmot-linudp.md §9 telegram 1: response definition
// 0x7F, no control word), encoded once.
inline std::vector<uint8_t> StatusPollTelegram() {
  linmot::linudp::Request req;
  req.response_definition = 0x7F;
  return linmot::linudp::EncodeRequest(req);
}

inline transport::UdpSocket BindLoopback() {
  auto sock = transport::UdpSocket::Bind(transport::Endpoint{0x7F000001, 0});
  if (!sock.ok()) Die("udp bind: " + std::string(sock.status().message()));
  return std::move(*sock);
}

// The round trip done on the calling thread: send, then block in recv for the reply — what the
// UDP baseline does, run inside the gRPC handler.
class InlineRoundTrip {
 public:
  explicit InlineRoundTrip(transport::Endpoint drive)
      : drive_(drive), sock_(BindLoopback()), telegram_(StatusPollTelegram()) {}

  void Run() {
    if (!sock_.SendTo(drive_, telegram_).ok()) Die("inline round trip: send failed");
    auto got = sock_.Receive(std::chrono::milliseconds(500));
    if (!got.ok() || !got->has_value()) Die("inline round trip: no reply");
  }

 private:
  transport::Endpoint drive_;
  transport::UdpSocket sock_;
  std::vector<uint8_t> telegram_;
};

// The round trip handed over as the gateway's LinUDP session does it (decisions 1301/1302): the
// caller arms a slot and sends the telegram from its own thread (Session::SendUrgentNow), a
// separate I/O thread blocked on the socket receives the reply and wakes the caller through a
// condition variable (InlineCompletion::Post, notified under its mutex). One call at a time.
class HandedOverRoundTrip {
 public:
  explicit HandedOverRoundTrip(transport::Endpoint drive)
      : drive_(drive), sock_(BindLoopback()), telegram_(StatusPollTelegram()) {
    io_ = std::thread([this] { IoLoop(); });
  }
  HandedOverRoundTrip(const HandedOverRoundTrip&) = delete;
  HandedOverRoundTrip& operator=(const HandedOverRoundTrip&) = delete;
  ~HandedOverRoundTrip() {
    sock_.Shutdown();  // releases the I/O thread's Receive
    io_.join();
  }

  void Run() {
    {
      std::lock_guard lock(mu_);
      armed_ = true;
      replied_ = false;
    }
    if (!sock_.SendTo(drive_, telegram_).ok()) Die("handed-over round trip: send failed");
    std::unique_lock lock(mu_);
    if (!cv_.wait_for(lock, std::chrono::milliseconds(500), [&] { return replied_; })) {
      Die("handed-over round trip: no reply");
    }
  }

 private:
  void IoLoop() {
    for (;;) {
      auto got = sock_.Receive(std::chrono::milliseconds(100));
      if (!got.ok()) return;  // shut down
      if (!got->has_value()) continue;
      std::lock_guard lock(mu_);
      if (!armed_) continue;  // a late reply to a call that gave up: the bench has died already
      armed_ = false;
      replied_ = true;
      cv_.notify_one();
    }
  }

  transport::Endpoint drive_;
  transport::UdpSocket sock_;
  std::vector<uint8_t> telegram_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool armed_ = false, replied_ = false;
  std::thread io_;
};

// The floor of a durable audit record: one INSERT of an audit-sized row in its own IMMEDIATE
// transaction on a prepared statement, in WAL mode with synchronous=NORMAL as storage/db.cpp opens
// the gateway's database (no hash chain, no retention, no JSON). What an accepted command cannot
// go below while its record must be durable before the reply leaves.
class BareAuditInsert {
 public:
  explicit BareAuditInsert(const std::string& path) {
    Check(sqlite3_open(path.c_str(), &db_), "open");
    Check(sqlite3_exec(
              db_,
              "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"
              "CREATE TABLE IF NOT EXISTS t (id INTEGER PRIMARY KEY, ts TEXT, principal TEXT,"
              " drive TEXT, action TEXT, request TEXT, code INTEGER, message TEXT)",
              nullptr, nullptr, nullptr),
          "schema");
    Check(sqlite3_prepare_v2(db_,
                             "INSERT INTO t (ts, principal, drive, action, request, code, message)"
                             " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
                             -1, &insert_, nullptr),
          "prepare");
  }
  BareAuditInsert(const BareAuditInsert&) = delete;
  BareAuditInsert& operator=(const BareAuditInsert&) = delete;
  ~BareAuditInsert() {
    sqlite3_finalize(insert_);
    sqlite3_close(db_);
  }

  void Commit() {
    static constexpr char kRequest[] =
        R"({"name":"drives/x1","position_mm":40,"velocity_mm_s":1000,"acceleration_mm_s2":10000})";
    Check(sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), "begin");
    sqlite3_bind_text(insert_, 1, "2026-11-27T18:00:00.000000Z", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert_, 2, "anonymous", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert_, 3, "x1", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert_, 4, "MoveAbsolute", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert_, 5, kRequest, -1, SQLITE_STATIC);
    sqlite3_bind_int(insert_, 6, 0);
    sqlite3_bind_text(insert_, 7, "", -1, SQLITE_STATIC);
    Check(sqlite3_step(insert_), "insert");
    sqlite3_reset(insert_);
    Check(sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr), "commit");
  }

 private:
  void Check(int rc, const char* what) {
    if (rc != SQLITE_OK && rc != SQLITE_DONE) {
      Die(std::string("sqlite ") + what + ": " + sqlite3_errmsg(db_));
    }
  }

  sqlite3* db_ = nullptr;
  sqlite3_stmt* insert_ = nullptr;
};

}  // namespace drivegw::bench
