// WebSocket status stream (decision 504): Beast websocket session over plain TCP or TLS that runs
// the router's in-process WatchDrives call and writes coalesced status frames. A Beast TU.
#include "server/rest/ws_session.h"

#include <boost/asio/post.hpp>
#include <boost/beast/core/bind_handler.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "adapters/core/log.h"
#include "google/protobuf/struct.pb.h"
#include "google/protobuf/util/json_util.h"
#include "server/rest/path_template.h"

namespace drivegw::rest {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
namespace pb = google::protobuf;
using beast::error_code;
using tcp = net::ip::tcp;
using TlsStream = net::ssl::stream<tcp::socket>;

constexpr int kInvalidArgument = 3;
constexpr int kNotFound = 5;
constexpr int kOutOfRange = 11;
constexpr int kInternal = 13;
constexpr int kUnauthenticated = 16;
constexpr int kPermissionDenied = 7;
constexpr std::string_view kDefaultRateHz = "10";  // the dashboard contract's default (issue 8)
constexpr size_t kMaxClientMessage = 4096;         // clients send nothing but control frames

std::string_view Sv(beast::string_view s) { return std::string_view(s.data(), s.size()); }

// RFC 3986 §2.3 unreserved characters stay, everything else is %XX.
std::string PercentEncode(std::string_view in) {
  std::string out;
  for (unsigned char c : in) {
    if (absl::ascii_isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      out.push_back(static_cast<char>(c));
    } else {
      absl::StrAppend(&out, "%", absl::Hex(c, absl::kZeroPad2));
    }
  }
  return out;
}

// {code, message} of a google.rpc.Status JSON body (ErrorResponse), as an error frame.
std::string ErrorFrame(const std::string& status_json) {
  pb::Struct status;
  int code = kInternal;
  std::string message = status_json;
  if (pb::util::JsonStringToMessage(status_json, &status).ok()) {
    const auto& f = status.fields();
    if (auto it = f.find("code"); it != f.end()) code = static_cast<int>(it->second.number_value());
    if (auto it = f.find("message"); it != f.end()) message = it->second.string_value();
  }
  pb::Value text;
  text.set_string_value(message);
  std::string quoted;
  if (!pb::util::MessageToJsonString(text, &quoted).ok()) quoted = "\"\"";
  return absl::StrCat("{\"type\":\"error\",\"code\":", code, ",\"message\":", quoted, "}");
}

// The drive name of a DriveStatus JSON line (its "name" field), "" if none.
std::string DriveNameOf(const std::string& status_json) {
  pb::Struct status;
  if (!pb::util::JsonStringToMessage(status_json, &status).ok()) return {};
  const auto& f = status.fields();
  auto it = f.find("name");
  return it == f.end() ? std::string() : it->second.string_value();
}

template <typename Stream>
class WsSession final : public SessionBase {
 public:
  WsSession(Stream stream, WsContext context) : ws_(std::move(stream)), ctx_(std::move(context)) {}

  ~WsSession() override {
    if (call_) call_->Cancel();
    ctx_.sessions->Remove(this);
  }

  void Run(WsRequest request) {
    ctx_.sessions->Add(this, weak_from_this());
    target_ = std::string(Sv(request.target()));
    if (ctx_.send_buffer > 0) {
      error_code ec;  // best effort: the kernel clamps to its own minimum
      beast::get_lowest_layer(ws_).set_option(net::socket_base::send_buffer_size(ctx_.send_buffer),
                                              ec);
    }
    websocket::stream_base::timeout timeout{};
    timeout.handshake_timeout = std::chrono::seconds(10);
    // Beast pings after half the idle time and closes when nothing (not even a pong) came back
    // by its end: a browser that vanished without a close frame is noticed (RFC 6455 §5.5.2).
    timeout.idle_timeout = ctx_.idle_timeout;
    timeout.keep_alive_pings = true;
    ws_.set_option(timeout);
    ws_.read_message_max(kMaxClientMessage);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "drivegw"); }));
    ws_.text(true);
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::OnAccept, Self()));
  }

  void CloseNow() override {
    closed_ = true;
    if (call_) call_->Cancel();
    error_code ec;
    beast::get_lowest_layer(ws_).close(ec);
  }

  // --- router events, on the strand ---
  void OnResponse(HttpResponse response) {
    // Refused before the stream started (bad query: 400).
    if (closed_) return;
    Fail(response.body);
  }
  void OnStreamStarted(std::shared_ptr<StreamCall> call) {
    if (closed_) {
      call->Cancel();
      return;
    }
    call_ = std::move(call);
    call_->RequestNext();
  }
  void OnStreamMessage(std::string line) {
    if (closed_) return;
    while (!line.empty() && line.back() == '\n') line.pop_back();
    std::string name = DriveNameOf(line);
    std::string frame = absl::StrCat("{\"type\":\"status\",\"status\":", line, "}");
    if (auto it = pending_.find(name); it != pending_.end()) {
      it->second = std::move(frame);  // latest snapshot wins
      ctx_.stats->frames_coalesced.fetch_add(1);
    } else if (pending_.size() < kWsMaxPendingDrives) {
      order_.push_back(name);
      pending_.emplace(std::move(name), std::move(frame));
      ctx_.stats->NotePending(pending_.size());
    } else {
      ctx_.stats->frames_coalesced.fetch_add(1);
    }
    // Keep draining the call: memory is bounded by pending_, not by the browser's pace.
    if (call_) call_->RequestNext();
    Pump();
  }
  void OnStreamEnd(HttpResponse end) {
    ctx_.stats->open_calls.fetch_sub(1);
    call_.reset();
    if (closed_) return;
    if (end.status != 200) return Fail(end.body);
    // The call ended without error: the gateway is shutting down.
    close_code_ = websocket::close_code::going_away;
    closing_ = true;
    Pump();
  }

 private:
  std::shared_ptr<WsSession> Self() {
    return std::static_pointer_cast<WsSession>(shared_from_this());
  }

  void OnAccept(error_code ec) {
    if (ec) {
      log::Debug("rest.ws_accept", log::Fields().Add("peer", ctx_.peer).Add("error", ec.message()));
      closed_ = true;
      return;
    }
    ctx_.stats->sessions.fetch_add(1);
    log::Debug("rest.ws_open", log::Fields().Add("peer", ctx_.peer).Add("target", target_));
    DoRead();
    auto request = WatchRequestFor(target_);
    if (!request.ok()) {
      return Fail(ErrorResponse(400, static_cast<int>(request.status().code()),
                                std::string(request.status().message()))
                      .body);
    }
    request->peer = ctx_.peer;
    request->client_cn = ctx_.client_cn;
    ctx_.stats->open_calls.fetch_add(1);
    ctx_.router->Handle(*std::move(request), std::make_shared<Sink>(Self()));
  }

  // Reads (and drops) client messages; Beast answers pings and close frames meanwhile. An
  // error here means the client is gone or closed: the watch is cancelled.
  void DoRead() {
    ws_.async_read(read_buffer_, beast::bind_front_handler(&WsSession::OnRead, Self()));
  }
  void OnRead(error_code ec, size_t) {
    read_buffer_.clear();
    if (ec) {
      if (ec != websocket::error::closed && ec != net::error::operation_aborted) {
        log::Debug("rest.ws_read", log::Fields().Add("peer", ctx_.peer).Add("error", ec.message()));
      }
      closed_ = true;
      if (call_) call_->Cancel();
      return;
    }
    DoRead();
  }

  // An error frame {"type":"error","code":...,"message":...}, then close.
  void Fail(const std::string& status_json) {
    if (closing_) return;
    error_frame_ = ErrorFrame(status_json);
    pb::Struct s;
    int code = kInternal;
    if (pb::util::JsonStringToMessage(status_json, &s).ok() && s.fields().count("code") > 0) {
      code = static_cast<int>(s.fields().at("code").number_value());
    }
    // RFC 6455 §7.4.1: 1008 for a refused credential, 1011 for anything else gone wrong.
    // The request's own fault (bad argument, unknown drive, out of range) counts as policy.
    const bool policy = code == kUnauthenticated || code == kPermissionDenied ||
                        code == kInvalidArgument || code == kNotFound || code == kOutOfRange;
    close_code_ =
        policy ? websocket::close_code::policy_error : websocket::close_code::internal_error;
    closing_ = true;
    pending_.clear();
    order_.clear();
    if (call_) call_->Cancel();
    Pump();
  }

  void Pump() {
    if (writing_ || closed_) return;
    std::shared_ptr<std::string> frame;
    if (!order_.empty()) {
      auto it = pending_.find(order_.front());
      order_.pop_front();
      frame = std::make_shared<std::string>(std::move(it->second));
      pending_.erase(it);
    } else if (error_frame_) {
      frame = std::make_shared<std::string>(std::move(*error_frame_));
      error_frame_.reset();
    } else if (closing_) {
      closed_ = true;
      writing_ = true;
      ws_.async_close(websocket::close_reason(close_code_),
                      [self = Self()](error_code) { self->writing_ = false; });
      return;
    } else {
      return;
    }
    writing_ = true;
    ws_.async_write(net::buffer(*frame), [self = Self(), frame](error_code ec, size_t) {
      self->writing_ = false;
      if (ec) {
        self->closed_ = true;
        if (self->call_) self->call_->Cancel();
        return;
      }
      self->ctx_.stats->frames_sent.fetch_add(1);
      self->Pump();
    });
  }

  // The router's view of the watch: forwards each event to the session's strand.
  class Sink final : public ResponseSink {
   public:
    explicit Sink(std::shared_ptr<WsSession> s) : s_(std::move(s)) {}
    void OnResponse(HttpResponse r) noexcept override {
      Post([s = s_, r = std::move(r)]() mutable {
        s->ctx_.stats->open_calls.fetch_sub(1);
        s->OnResponse(std::move(r));
      });
    }
    void OnStreamStarted(std::shared_ptr<StreamCall> c) noexcept override {
      Post([s = s_, c = std::move(c)]() mutable { s->OnStreamStarted(std::move(c)); });
    }
    void OnStreamMessage(std::string line) noexcept override {
      Post([s = s_, l = std::move(line)]() mutable { s->OnStreamMessage(std::move(l)); });
    }
    void OnStreamEnd(HttpResponse end) noexcept override {
      Post([s = s_, e = std::move(end)]() mutable { s->OnStreamEnd(std::move(e)); });
    }

   private:
    template <typename F>
    void Post(F&& f) noexcept {
      try {
        net::post(s_->ws_.get_executor(), std::forward<F>(f));
      } catch (const std::exception& e) {
        log::Error("rest.ws_post", log::Fields().Add("error", e.what()));
      }
    }
    std::shared_ptr<WsSession> s_;
  };

  websocket::stream<Stream> ws_;
  WsContext ctx_;
  std::string target_;
  beast::flat_buffer read_buffer_;
  std::shared_ptr<StreamCall> call_;
  std::map<std::string, std::string> pending_;  // drive name -> latest unsent frame
  std::deque<std::string> order_;               // names in pending_, oldest first
  std::optional<std::string> error_frame_;
  websocket::close_code close_code_ = websocket::close_code::normal;
  bool writing_ = false;
  bool closing_ = false;  // error frame (if any), then close
  bool closed_ = false;
};

}  // namespace

bool IsWsUpgrade(const WsRequest& request) {
  if (!websocket::is_upgrade(request)) return false;
  const std::string_view target = Sv(request.target());
  return target.substr(0, target.find('?')) == kWsPath;
}

absl::StatusOr<HttpRequest> WatchRequestFor(std::string_view target) {
  const size_t q = target.find('?');
  const std::string_view query = q == std::string_view::npos ? "" : target.substr(q + 1);
  std::string rate(kDefaultRateHz);
  std::vector<std::string> names;
  std::string token;
  for (absl::string_view raw :
       absl::StrSplit(absl::string_view(query.data(), query.size()), '&', absl::SkipEmpty())) {
    const std::string_view pair(raw.data(), raw.size());
    const size_t eq = pair.find('=');
    auto key = PercentDecode(pair.substr(0, eq), false, true);
    auto value =
        PercentDecode(eq == std::string_view::npos ? "" : pair.substr(eq + 1), false, true);
    if (!key || !value) {
      return absl::InvalidArgumentError(
          absl::StrCat("query: malformed percent-encoding in ", std::string(pair)));
    }
    if (*key == "max_rate_hz") {
      rate = *value;
    } else if (*key == "names") {
      for (absl::string_view n : absl::StrSplit(*value, ',', absl::SkipEmpty())) {
        names.emplace_back(n.data(), n.size());
      }
    } else if (*key == "access_token") {
      token = *value;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          "query parameter ", *key, ": unknown (known: max_rate_hz, names, access_token)"));
    }
  }
  HttpRequest request;
  request.method = "GET";
  request.target = absl::StrCat("/v1/drives:watch?max_rate_hz=", PercentEncode(rate));
  for (const auto& n : names) absl::StrAppend(&request.target, "&names=", PercentEncode(n));
  // Browsers cannot set headers on a WebSocket: the token rides in the query and becomes the
  // same Authorization the REST routes forward (issue 8 contract, decision 504).
  if (!token.empty()) request.authorization = absl::StrCat("Bearer ", token);
  return request;
}

void StartWsSession(tcp::socket socket, WsRequest request, WsContext context) {
  std::make_shared<WsSession<tcp::socket>>(std::move(socket), std::move(context))
      ->Run(std::move(request));
}

void StartWsSession(TlsStream stream, WsRequest request, WsContext context) {
  std::make_shared<WsSession<TlsStream>>(std::move(stream), std::move(context))
      ->Run(std::move(request));
}

}  // namespace drivegw::rest
