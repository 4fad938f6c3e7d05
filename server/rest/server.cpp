// REST server: Beast listener and HTTP/1.1 sessions (keep-alive, bounded pipelining, chunked
// NDJSON streams, deadlines) over plain TCP or TLS (decision 023) in front of the socketless
// router. The only Beast TU of dgw_rest.
#include "server/rest/server.h"

#include <array>
#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/bind_handler.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "server/rest/request_reader.h"
#include "server/rest/response_head.h"
#include "server/rest/router.h"
#include "server/rest/session_registry.h"
#include "server/rest/ws_session.h"

namespace drivegw::rest {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using beast::error_code;
using TlsStream = net::ssl::stream<tcp::socket>;

constexpr size_t kMaxPipelined = 8;  // requests read ahead of their responses
constexpr auto kLingerTime = std::chrono::seconds(1);
constexpr size_t kLingerBytes = 1 << 20;
constexpr size_t kKeptHeadCapacity = 4096;  // a session's head buffer kept between responses

std::string Str(beast::string_view s) { return std::string(s.data(), s.size()); }

std::string PeerString(const tcp::endpoint& ep) {
  const auto address = ep.address();
  return address.is_v6() ? absl::StrCat("[", address.to_string(), "]:", ep.port())
                         : absl::StrCat(address.to_string(), ":", ep.port());
}

// A wait that completed may have been re-armed meanwhile (its handler was already queued).
bool Expired(const net::steady_timer& t) {
  return t.expiry() <= net::steady_timer::clock_type::now();
}

// The Exchange whose request the router is handling on this thread right now (set around
// Router::Handle in Session::OnRead, which runs on the session's strand): a response it gets
// inline is stored directly instead of being posted back to the strand it is already on.
thread_local const void* t_inline_exchange = nullptr;

// State every session reads; owned by RestServer::Impl, which outlives the sessions.
struct Shared {
  RestOptions options;
  std::unique_ptr<Router> router;
  std::optional<net::ssl::context> tls;  // set for HTTPS
  SessionRegistry sessions;              // HTTP and WebSocket connections
  WsStats ws_stats;
};

// One connection over `Stream` (tcp::socket, or TlsStream for HTTPS). All members are touched
// on the socket's strand only; router callbacks come in through Exchange, which posts them there.
template <typename Stream>
class Session final : public SessionBase {
 public:
  static constexpr bool kTls = std::is_same_v<Stream, TlsStream>;

  // `stream_args`: the accepted socket, and for TLS the shared context.
  template <typename... Args>
  Session(Shared& shared, Args&&... stream_args)
      : stream_(std::forward<Args>(stream_args)...),
        shared_(shared),
        idle_timer_(stream_.get_executor()),
        write_timer_(stream_.get_executor()) {
    slots_.reserve(kMaxPipelined);
    error_code ec;
    const auto ep = Socket().remote_endpoint(ec);
    peer_ = ec ? "unknown" : PeerString(ep);
  }

  ~Session() {
    for (auto& slot : slots_) {
      if (slot.stream) slot.stream->Cancel();
    }
    shared_.sessions.Remove(this);
  }

  void Run() {
    shared_.sessions.Add(this, weak_from_this());
    net::post(stream_.get_executor(), [self = Self()] {
      if constexpr (kTls) {
        self->DoHandshake();
      } else {
        self->DoRead();
      }
    });
  }

  // For RestServer::Stop once the I/O threads are joined (no other thread touches us then).
  void CloseNow() override {
    if (!closed_) DoCloseState();
    error_code ec;
    Socket().shutdown(tcp::socket::shutdown_send, ec);
    CloseSocket();  // also ends a lingering close
  }

  // --- router events, on the strand (posted by Exchange) ---
  void OnResponse(uint64_t id, HttpResponse response) {
    if (Slot* s = Find(id)) s->response = std::move(response);
    Pump();
  }
  void OnStreamStarted(uint64_t id, std::shared_ptr<StreamCall> stream) {
    Slot* s = Find(id);
    if (s == nullptr) {  // connection already gone
      stream->Cancel();
      return;
    }
    s->stream = std::move(stream);
    s->streaming = true;
    s->stream->RequestNext();
  }
  void OnStreamMessage(uint64_t id, std::string line) {
    if (Slot* s = Find(id)) s->lines.push_back(std::move(line));
    Pump();
  }
  void OnStreamEnd(uint64_t id, HttpResponse end) {
    if (Slot* s = Find(id)) {
      s->end = std::move(end);
      s->stream.reset();
    }
    Pump();
  }

 private:
  // One request in arrival order, with its response as it becomes ready.
  struct Slot {
    uint64_t id = 0;
    unsigned version = 11;
    bool keep_alive = true;
    std::string method, target;
    std::optional<HttpResponse> response;  // a whole response
    bool streaming = false;                // an NDJSON stream (OnStreamStarted seen)
    std::shared_ptr<StreamCall> stream;    // until OnStreamEnd
    // At most one line waits: the stream gets RequestNext only once the line before is written.
    // A vector, as slots_: an empty std::deque allocates its map and a node (issue 10, P4).
    std::vector<std::string> lines;
    std::optional<HttpResponse> end;
    bool head_sent = false;
    bool error_line_sent = false;
  };

  std::shared_ptr<Session> Self() { return std::static_pointer_cast<Session>(shared_from_this()); }
  tcp::socket& Socket() {
    if constexpr (kTls) {
      return stream_.next_layer();
    } else {
      return stream_;
    }
  }

  // --- TLS ---
  // The handshake must complete within handshake_timeout; a failed one (no or an unverified
  // client certificate when one is required, a plain-HTTP client) just closes the connection.
  void DoHandshake() {
    idle_timer_.expires_after(shared_.options.handshake_timeout);
    idle_timer_.async_wait([self = Self()](error_code ec) {
      if (!ec && !self->handshake_done_ && Expired(self->idle_timer_)) {
        log::Debug("rest.tls_handshake_timeout", log::Fields().Add("peer", self->peer_));
        self->CloseSocket();
      }
    });
    if constexpr (kTls) {
      stream_.async_handshake(net::ssl::stream_base::server,
                              beast::bind_front_handler(&Session::OnHandshake, Self()));
    }
  }

  void OnHandshake(error_code ec) {
    idle_timer_.cancel();
    if (ec) {
      log::Debug("rest.tls_handshake", log::Fields().Add("peer", peer_).Add("error", ec.message()));
      closed_ = true;
      return CloseSocket();
    }
    handshake_done_ = true;
    if constexpr (kTls) client_cn_ = VerifiedClientCommonName(stream_.native_handle());
    DoRead();
  }

  // Sends close_notify and waits (briefly) for the peer's, so a body that ends with the
  // connection is not taken for a truncation attack; a stuck peer is cut off after kLingerTime.
  void TlsShutdown() {
    error_code ec;
    if (!handshake_done_ || writing_) return CloseSocket();
    Socket().cancel(ec);  // a pending read-ahead ends (OnRead sees closed_)
    write_timer_.expires_after(kLingerTime);
    write_timer_.async_wait([self = Self()](error_code wait_ec) {
      if (!wait_ec) self->CloseSocket();
    });
    if constexpr (kTls) {
      stream_.async_shutdown([self = Self()](error_code) { self->CloseSocket(); });
    }
  }

  Slot* Find(uint64_t id) {
    for (auto& s : slots_) {
      if (s.id == id) return &s;
    }
    return nullptr;
  }

  // --- reading ---
  void DoRead() {
    if (reading_ || closed_ || peer_done_ || slots_.size() >= kMaxPipelined) return;
    parser_.emplace();
    ConfigureRequestParser(*parser_, shared_.options.body_limit);
    reading_ = true;
    UpdateIdleDeadline();
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&Session::OnRead, Self()));
  }

  void OnRead(error_code ec, size_t /*bytes*/) {
    reading_ = false;
    if (closed_) return;
    if (ec == http::error::end_of_stream) {
      // The client closed (or half-closed) its side: a stream has nobody to go to; pending
      // whole responses are still written, then the connection closes.
      peer_done_ = true;
      for (auto& s : slots_) {
        if (s.stream) s.stream->Cancel();
      }
      if (slots_.empty()) DoClose();
      return;
    }
    if (auto rejection = RejectionFor(ec, shared_.options.body_limit)) {
      return Reject(*std::move(rejection));
    }
    if (ec) {
      if (ec != net::error::operation_aborted) {
        log::Debug("rest.read", log::Fields().Add("peer", peer_).Add("error", ec.message()));
      }
      return DoClose();
    }

    auto req = parser_->release();
    // GET /v1/drives:ws with Upgrade: websocket leaves HTTP for good (RFC 6455 §4.2; decision
    // 504): the socket moves to a WsSession. Only on an otherwise idle connection, so no
    // response of this session is still owed.
    if (accepting_ && slots_.empty() && !writing_ && IsWsUpgrade(req)) {
      closed_ = true;
      idle_timer_.cancel();
      write_timer_.cancel();
      StartWsSession(std::move(stream_), std::move(req),
                     WsContext{shared_.router.get(), &shared_.sessions, &shared_.ws_stats,
                               shared_.options.read_timeout, shared_.options.ws_send_buffer, peer_,
                               client_cn_});
      return;
    }
    if (!accepting_) {  // requests after "Connection: close" are ignored; keep watching EOF
      DoRead();
      return;
    }
    Slot& slot = slots_.emplace_back();
    slot.id = next_id_++;
    slot.version = req.version();
    slot.keep_alive = req.keep_alive();
    slot.method = Str(req.method_string());
    slot.target = Str(req.target());
    accepting_ = slot.keep_alive;
    HttpRequest request{slot.method,
                        slot.target,
                        std::move(req.body()),
                        peer_,
                        Str(req[http::field::if_match]),
                        Str(req[http::field::authorization]),
                        Str(req["Idempotency-Key"]),
                        client_cn_,
                        Str(req["X-Drivegw-Lease"])};
    const uint64_t id = slot.id;
    UpdateIdleDeadline();
    auto exchange = std::make_shared<Exchange>(Self(), id);
    t_inline_exchange = exchange.get();
    shared_.router->Handle(std::move(request), std::move(exchange));
    t_inline_exchange = nullptr;
    Pump();    // an answer given inline (fixed routes, direct reads, early errors)
    DoRead();  // read ahead (pipelining) and notice a client that goes away
  }

  // Answers a request the parser could not take, then closes: the rest of the stream has no
  // known framing.
  void Reject(HttpResponse response) {
    log::Debug("rest.reject", log::Fields().Add("peer", peer_).Add("status", response.status));
    Slot& slot = slots_.emplace_back();
    slot.id = next_id_++;
    slot.keep_alive = false;
    slot.response = std::move(response);
    accepting_ = false;
    peer_done_ = true;  // read no further
    UpdateIdleDeadline();
    Pump();
  }

  // A request must arrive in full within read_timeout of the connection going idle (no
  // response pending): idle keep-alive connections and slow senders are closed; read-ahead
  // while responses are pending or streaming has no deadline of its own.
  // Deadlines are values: moving one costs no timer operation. Each timer is armed at most once
  // at a time and, when it fires early because its deadline moved, re-arms itself for the new
  // one (cancelling and re-arming per request cost a timerfd update and an aborted handler on
  // the strand each, twice per request; issue 10, P4).
  void UpdateIdleDeadline() {
    if (slots_.empty() && reading_) {
      idle_deadline_ = net::steady_timer::clock_type::now() + shared_.options.read_timeout;
      ArmIdleTimer();
    } else {
      idle_deadline_ = net::steady_timer::time_point::max();  // not idle: no deadline
    }
  }

  void ArmIdleTimer() {
    if (idle_armed_ || closed_) return;
    idle_armed_ = true;
    idle_timer_.expires_at(idle_deadline_);
    idle_timer_.async_wait([self = Self()](error_code ec) {
      self->idle_armed_ = false;
      if (ec || self->closed_ || self->idle_deadline_ == net::steady_timer::time_point::max()) {
        return;  // cancelled, closed, or busy (the next idle period arms it again)
      }
      if (net::steady_timer::clock_type::now() < self->idle_deadline_) {
        return self->ArmIdleTimer();  // the deadline moved on
      }
      if (self->slots_.empty() && self->reading_) {
        log::Debug("rest.idle_timeout", log::Fields().Add("peer", self->peer_));
        self->DoClose();
      }
    });
  }

  // --- writing ---
  void Pump() {
    if (writing_ || closed_ || slots_.empty()) return;
    Slot& s = slots_.front();
    if (s.response) return WriteWhole(s, *s.response);
    if (!s.streaming) return;  // the router has not answered yet
    if (!s.head_sent) {
      if (!s.lines.empty() || (s.end && s.end->status == 200)) return WriteStreamHead(s);
      if (s.end) return WriteWhole(s, *s.end);  // failed before its first message
      return;
    }
    if (!s.lines.empty()) {
      auto line = std::make_shared<std::string>(std::move(s.lines.front()));
      s.lines.erase(s.lines.begin());
      return WriteBody(s, std::move(line), /*last=*/false);
    }
    if (s.end) {
      if (s.end->status != 200 && !s.error_line_sent) {
        s.error_line_sent = true;
        auto line = std::make_shared<std::string>(absl::StrCat("{\"error\":", s.end->body, "}\n"));
        return WriteBody(s, std::move(line), /*last=*/false);
      }
      return WriteBody(s, nullptr, /*last=*/true);
    }
  }

  // Every write must finish within read_timeout; a lazy deadline as UpdateIdleDeadline's.
  void StartWriteDeadline() {
    writing_ = true;
    write_deadline_ = net::steady_timer::clock_type::now() + shared_.options.read_timeout;
    ArmWriteTimer();
  }

  void ArmWriteTimer() {
    if (write_armed_ || closed_) return;
    write_armed_ = true;
    write_timer_.expires_at(write_deadline_);
    write_timer_.async_wait([self = Self()](error_code ec) {
      self->write_armed_ = false;
      if (ec || self->closed_ || !self->writing_) return;  // the next write arms it again
      if (net::steady_timer::clock_type::now() < self->write_deadline_) {
        return self->ArmWriteTimer();  // the deadline moved on
      }
      log::Debug("rest.write_timeout", log::Fields().Add("peer", self->peer_));
      self->DoClose();
    });
  }

  bool KeepAlive(const Slot& s) const { return s.keep_alive && !peer_done_ && accepting_; }

  // Takes r.body: the slot is done with once written. The head is written into a buffer the
  // session reuses, with the bytes Beast's serializer would write (AppendResponseHead), and
  // sent with the body in one gather write: no Beast message, no field allocations, no
  // serializer per response (decision 1365). Heads AppendResponseHead leaves to Beast go the
  // way they went before.
  void WriteWhole(Slot& s, HttpResponse& r) {
    LogResponse(s, r.status);
    const bool keep_alive = KeepAlive(s);
    out_head_.clear();
    if (AppendResponseHead(r, s.version, keep_alive, out_head_)) {
      out_body_ = std::move(r.body);
      StartWriteDeadline();
      const std::array<net::const_buffer, 2> buffers{net::buffer(out_head_),
                                                     net::buffer(out_body_)};
      net::async_write(stream_, buffers,
                       [self = Self(), close = !keep_alive](error_code ec, size_t) {
                         self->ReleaseWholeResponse();
                         self->OnWritten(ec, /*done=*/true, close);
                       });
      return;
    }
    auto res = std::make_shared<http::response<http::string_body>>(
        static_cast<http::status>(r.status), s.version);
    res->set(http::field::server, "drivegw");
    res->set(http::field::content_type, r.content_type);
    for (const auto& [name, value] : r.headers) res->set(name, value);
    res->keep_alive(keep_alive);
    res->body() = std::move(r.body);
    res->prepare_payload();
    StartWriteDeadline();
    http::async_write(stream_, *res, [self = Self(), res](error_code ec, size_t) {
      self->OnWritten(ec, /*done=*/true, !res->keep_alive());
    });
  }

  // After a whole response's write: its body is freed as the Beast message was; the head's
  // buffer is kept for the next response unless an unusually large head grew it.
  void ReleaseWholeResponse() {
    out_body_ = std::string();
    if (out_head_.capacity() > kKeptHeadCapacity) out_head_ = std::string();
  }

  void LogResponse(const Slot& s, int status) const {
    if (log::Enabled(log::Level::kDebug)) {  // the fields cost more than the check
      log::Debug("rest.response", log::Fields()
                                      .Add("peer", peer_)
                                      .Add("method", s.method)
                                      .Add("target", s.target)
                                      .Add("status", status));
    }
  }

  void WriteStreamHead(Slot& s) {
    s.head_sent = true;
    auto res = std::make_shared<http::response<http::empty_body>>(http::status::ok, s.version);
    res->set(http::field::server, "drivegw");
    res->set(http::field::content_type, "application/x-ndjson");
    res->set(http::field::cache_control, "no-cache");
    // HTTP/1.0 has no chunked encoding: the body then ends when the connection closes.
    if (s.version >= 11) {
      res->chunked(true);
      res->keep_alive(KeepAlive(s));
    } else {
      res->keep_alive(false);
      s.keep_alive = false;
    }
    auto sr = std::make_shared<http::response_serializer<http::empty_body>>(*res);
    log::Debug("rest.stream", log::Fields().Add("peer", peer_).Add("target", s.target));
    StartWriteDeadline();
    http::async_write_header(stream_, *sr, [self = Self(), res, sr](error_code ec, size_t) {
      self->OnWritten(ec, /*done=*/false, false);
    });
  }

  void WriteBody(Slot& s, std::shared_ptr<std::string> line, bool last) {
    StartWriteDeadline();
    auto self = Self();
    const bool chunked = s.version >= 11;
    const bool close_after = last && !KeepAlive(s);
    if (last) {
      if (!chunked) return OnWritten({}, /*done=*/true, /*close=*/true);
      net::async_write(stream_, http::make_chunk_last(),
                       [self, close_after](error_code ec, size_t) {
                         self->OnWritten(ec, /*done=*/true, close_after);
                       });
      return;
    }
    auto on_done = [self, line, stream = s.stream](error_code ec, size_t) {
      self->OnWritten(ec, /*done=*/false, false);
      if (!ec && stream) stream->RequestNext();  // flow control: one line in flight
    };
    if (chunked) {
      net::async_write(stream_, http::make_chunk(net::buffer(*line)), std::move(on_done));
    } else {
      net::async_write(stream_, net::buffer(*line), std::move(on_done));
    }
  }

  void OnWritten(error_code ec, bool done, bool close) {
    writing_ = false;  // the write timer, if it fires, sees nothing to watch
    if (closed_) return;
    if (ec) {
      log::Debug("rest.write", log::Fields().Add("peer", peer_).Add("error", ec.message()));
      return DoClose();
    }
    if (done) {
      slots_.erase(slots_.begin());
      if (close) return LingerClose();
      if (slots_.empty() && peer_done_) return DoClose();
      UpdateIdleDeadline();
      DoRead();  // resumes a read paused by the pipelining bound
    }
    Pump();
  }

  void DoClose() {
    if (closed_) return;
    DoCloseState();
    if constexpr (kTls) return TlsShutdown();
    error_code ec;
    Socket().shutdown(tcp::socket::shutdown_send, ec);
    CloseSocket();
  }

  void DoCloseState() {
    closed_ = true;
    for (auto& s : slots_) {
      if (s.stream) s.stream->Cancel();
    }
    slots_.clear();
    idle_timer_.cancel();
    write_timer_.cancel();
  }

  // Closes after a "Connection: close" response without a reset: the client may still be
  // sending (e.g. the body of a 413), and unread data at close() makes the kernel send RST,
  // which can destroy the response in flight. So: FIN, then read and drop for a short while.
  void LingerClose() {
    if (closed_) return;
    error_code ec;
    Socket().cancel(ec);  // a pending read-ahead ends (OnRead sees closed_)
    DoCloseState();
    if constexpr (kTls) return TlsShutdown();  // close_notify plays the part of the FIN
    Socket().shutdown(tcp::socket::shutdown_send, ec);
    write_timer_.expires_after(kLingerTime);
    write_timer_.async_wait([self = Self()](error_code wait_ec) {
      if (!wait_ec) self->CloseSocket();
    });
    Drain(std::make_shared<std::array<char, 4096>>(), 0);
  }

  void Drain(std::shared_ptr<std::array<char, 4096>> buf, size_t total) {
    Socket().async_read_some(net::buffer(*buf),
                             [self = Self(), buf, total](error_code ec, size_t n) {
                               if (ec || total + n > kLingerBytes) return self->CloseSocket();
                               self->Drain(buf, total + n);
                             });
  }

  void CloseSocket() {
    error_code ec;
    write_timer_.cancel();
    Socket().close(ec);
  }

  // The router's view of one request: forwards each event to the session's strand.
  class Exchange final : public ResponseSink {
   public:
    Exchange(std::shared_ptr<Session> session, uint64_t id)
        : session_(std::move(session)), id_(id) {}
    void OnResponse(HttpResponse response) noexcept override {
      if (t_inline_exchange == this) {  // inside Handle, on the strand: OnRead pumps next
        if (Slot* s = session_->Find(id_)) s->response = std::move(response);
        return;
      }
      Post([s = session_, id = id_, r = std::move(response)]() mutable {
        s->OnResponse(id, std::move(r));
      });
    }
    void OnStreamStarted(std::shared_ptr<StreamCall> stream) noexcept override {
      Post([s = session_, id = id_, stream = std::move(stream)]() mutable {
        s->OnStreamStarted(id, std::move(stream));
      });
    }
    void OnStreamMessage(std::string line) noexcept override {
      Post([s = session_, id = id_, l = std::move(line)]() mutable {
        s->OnStreamMessage(id, std::move(l));
      });
    }
    void OnStreamEnd(HttpResponse end) noexcept override {
      Post([s = session_, id = id_, e = std::move(end)]() mutable {
        s->OnStreamEnd(id, std::move(e));
      });
    }

   private:
    template <typename F>
    void Post(F&& f) noexcept {
      try {
        net::post(session_->stream_.get_executor(), std::forward<F>(f));
      } catch (const std::exception& e) {
        log::Error("rest.post", log::Fields().Add("error", e.what()));
      }
    }
    std::shared_ptr<Session> session_;
    uint64_t id_;
  };

  Stream stream_;
  Shared& shared_;
  std::string peer_;
  std::string client_cn_;  // subject CN of the verified client certificate (TLS), else ""
  bool handshake_done_ = !kTls;
  beast::flat_buffer buffer_;
  // The whole response being written (WriteWhole): its head, in a buffer reused per response
  // (cleared before each), and its body. One write at a time (writing_).
  std::string out_head_;
  std::string out_body_;
  std::optional<http::request_parser<http::string_body>> parser_;
  net::steady_timer idle_timer_;
  net::steady_timer write_timer_;
  net::steady_timer::time_point idle_deadline_ = net::steady_timer::time_point::max();
  net::steady_timer::time_point write_deadline_ = net::steady_timer::time_point::max();
  bool idle_armed_ = false;   // an ArmIdleTimer wait is pending
  bool write_armed_ = false;  // an ArmWriteTimer wait is pending
  // Requests in arrival order, at most kMaxPipelined (DoRead reads no further then): a vector
  // reserved once, so a request costs no allocation here (a std::deque of Slots allocated a node
  // per request; decision 1364).
  std::vector<Slot> slots_;
  uint64_t next_id_ = 1;
  bool reading_ = false;
  bool writing_ = false;
  bool accepting_ = true;   // false after a request without keep-alive
  bool peer_done_ = false;  // EOF seen or framing lost: read no more
  bool closed_ = false;
};

}  // namespace

struct RestServer::Impl {
  Shared shared;
  net::io_context ioc;  // destroyed before `shared`: pending handlers release sessions first
  tcp::acceptor acceptor{net::make_strand(ioc)};
  net::steady_timer accept_retry{acceptor.get_executor()};
  std::vector<std::thread> threads;
  uint16_t port = 0;
  std::atomic<bool> stopped{false};

  explicit Impl(int threads_hint) : ioc(std::max(1, threads_hint)) {}

  void DoAccept() {
    acceptor.async_accept(net::make_strand(ioc), [this](error_code ec, tcp::socket socket) {
      if (!acceptor.is_open() || ec == net::error::operation_aborted) return;
      if (ec) {  // e.g. EMFILE: retry shortly instead of spinning
        log::Warn("rest.accept", log::Fields().Add("error", ec.message()));
        accept_retry.expires_after(std::chrono::milliseconds(100));
        accept_retry.async_wait([this](error_code wait_ec) {
          if (!wait_ec) DoAccept();
        });
        return;
      }
      error_code nodelay_ec;
      socket.set_option(tcp::no_delay(true), nodelay_ec);
      if (shared.tls) {
        std::make_shared<Session<TlsStream>>(shared, std::move(socket), *shared.tls)->Run();
      } else {
        std::make_shared<Session<tcp::socket>>(shared, std::move(socket))->Run();
      }
      DoAccept();
    });
  }
};

absl::StatusOr<std::unique_ptr<RestServer>> RestServer::Start(RestOptions options) {
  if (options.channel == nullptr) return absl::InvalidArgumentError("rest: no gRPC channel");
  if (options.body_limit == 0) return absl::InvalidArgumentError("rest.body_limit: 0 bytes");
  if (options.read_timeout.count() <= 0) {
    return absl::InvalidArgumentError("rest.read_timeout: must be positive");
  }
  RouterOptions router_options;
  router_options.channel = options.channel;
  router_options.openapi_json = options.openapi_json;
  router_options.more_services = options.more_services;
  router_options.static_dir = options.static_dir;
  router_options.web_assets = options.web_assets;
  router_options.fixed_routes = options.fixed_routes;
  router_options.direct_unary = options.direct_unary;
  auto router = Router::Create(std::move(router_options));
  if (!router.ok()) return router.status();

  auto impl = std::make_unique<Impl>(options.threads);
  impl->shared.router = *std::move(router);
  if (options.tls) {
    impl->shared.tls.emplace(net::ssl::context::tls_server);
    if (absl::Status s = ConfigureTlsContext(*options.tls, *impl->shared.tls); !s.ok()) return s;
  }
  error_code ec;
  const auto address = net::ip::make_address(options.listen_address, ec);
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat("rest.listen_address: \"", options.listen_address, "\": ", ec.message()));
  }
  const tcp::endpoint endpoint(address, options.port);
  auto& acc = impl->acceptor;
  if (acc.open(endpoint.protocol(), ec); !ec)
    acc.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acc.bind(endpoint, ec);
  if (!ec) acc.listen(net::socket_base::max_listen_connections, ec);
  if (ec) {
    return absl::UnavailableError(absl::StrCat("rest: cannot listen on ", options.listen_address,
                                               ":", options.port, ": ", ec.message()));
  }
  impl->port = acc.local_endpoint(ec).port();
  impl->shared.options = std::move(options);
  impl->DoAccept();
  const int threads = std::max(1, impl->shared.options.threads);
  for (int i = 0; i < threads; ++i) {
    impl->threads.emplace_back([ioc = &impl->ioc] {
      for (;;) {
        try {
          ioc->run();
          return;
        } catch (const std::exception& e) {  // a handler threw: log, keep serving
          log::Error("rest.handler_exception", log::Fields().Add("error", e.what()));
        }
      }
    });
  }
  log::Info("rest.listening", log::Fields()
                                  .Add("address", impl->shared.options.listen_address)
                                  .Add("port", impl->port)
                                  .Add("tls", impl->shared.tls ? "true" : "false")
                                  .Add("routes", impl->shared.router->routes().size()));
  return std::unique_ptr<RestServer>(new RestServer(std::move(impl)));
}

RestServer::RestServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

RestServer::~RestServer() { Stop(); }

uint16_t RestServer::port() const { return impl_->port; }

const WsStats& RestServer::ws_stats() const { return impl_->shared.ws_stats; }

void RestServer::Stop() {
  if (impl_->stopped.exchange(true)) return;
  // Cancelled calls complete promptly and only post to their sessions; new requests get 503.
  impl_->shared.router->CancelAll();
  impl_->ioc.stop();
  for (auto& t : impl_->threads) t.join();
  impl_->threads.clear();
  impl_->shared.router->WaitIdle(std::chrono::milliseconds::max());
  // No I/O thread runs now: close the listener and every connection here, then run what the
  // closing completed so sessions are released.
  error_code ec;
  impl_->acceptor.close(ec);
  impl_->accept_retry.cancel();
  std::vector<std::shared_ptr<SessionBase>> sessions = impl_->shared.sessions.Live();
  for (auto& s : sessions) s->CloseNow();
  sessions.clear();
  try {
    impl_->ioc.restart();
    for (int i = 0; i < 1000 && impl_->ioc.poll() > 0; ++i) {
    }
  } catch (const std::exception& e) {
    log::Error("rest.handler_exception", log::Fields().Add("error", e.what()));
  }
  log::Info("rest.stopped", log::Fields().Add("port", impl_->port));
}

}  // namespace drivegw::rest
