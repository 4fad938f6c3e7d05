// A small Beast WebSocket client for the dashboard stream tests: every step runs the client's
// own io_context for at most a deadline, so a silent server fails the test instead of hanging.
#pragma once

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <boost/beast/core/buffers_to_string.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>

namespace drivegw::rest::test_support {

// NextLayer: tcp::socket (ws://) or ssl::stream<tcp::socket> (wss://, then pass the context).
template <typename NextLayer>
class BasicWsClient {
 public:
  static constexpr std::chrono::seconds kTimeout{20};
  static constexpr bool kTls = !std::is_same_v<NextLayer, boost::asio::ip::tcp::socket>;
  using Ws = boost::beast::websocket::stream<NextLayer>;

  BasicWsClient() requires(!kTls) : ws_(ioc_) {}
  explicit BasicWsClient(boost::asio::ssl::context& tls) requires(kTls) : ws_(ioc_, tls) {}

  // Connects to 127.0.0.1:port and completes the handshake for `target`. rcvbuf > 0 shrinks
  // the socket's receive buffer (a reader that falls behind fills it soon).
  bool Connect(uint16_t port, const std::string& target, int rcvbuf = 0) {
    namespace net = boost::asio;
    boost::beast::error_code ec;
    auto& sock = boost::beast::get_lowest_layer(ws_);
    sock.open(net::ip::tcp::v4(), ec);
    if (rcvbuf > 0) sock.set_option(net::socket_base::receive_buffer_size(rcvbuf), ec);
    sock.connect({net::ip::make_address("127.0.0.1"), port}, ec);
    if (ec) return false;
    bool done = false;
    if constexpr (kTls) {
      ws_.next_layer().async_handshake(boost::asio::ssl::stream_base::client,
                                       [&](boost::beast::error_code e) {
                                         ec = e;
                                         done = true;
                                       });
      if (!Run(done) || ec) return false;
      done = false;
    }
    ws_.async_handshake("127.0.0.1", target, [&](boost::beast::error_code e) {
      ec = e;
      done = true;
    });
    return Run(done) && !ec;
  }

  // The next text frame; nullopt on close, error or timeout (close_reason() tells a close).
  std::optional<std::string> Read(std::chrono::milliseconds timeout = kTimeout) {
    boost::beast::flat_buffer buffer;
    boost::beast::error_code ec;
    bool done = false;
    ws_.async_read(buffer, [&](boost::beast::error_code e, size_t) {
      ec = e;
      done = true;
    });
    if (!Run(done, timeout) || ec) {
      last_error_ = ec;
      return std::nullopt;
    }
    return boost::beast::buffers_to_string(buffer.data());
  }

  // Ends the TCP connection without a close frame (a browser tab killed).
  void Drop() {
    boost::beast::error_code ec;
    boost::beast::get_lowest_layer(ws_).close(ec);
  }

  // Sends one text message (the server accepts at most 4096 bytes, ws_session.cpp).
  bool Write(const std::string& text) {
    bool done = false;
    boost::beast::error_code ec;
    ws_.text(true);
    ws_.async_write(boost::asio::buffer(text), [&](boost::beast::error_code e, size_t) {
      ec = e;
      done = true;
    });
    return Run(done) && !ec;
  }

  void Close() {
    bool done = false;
    ws_.async_close(boost::beast::websocket::close_code::normal,
                    [&](boost::beast::error_code) { done = true; });
    Run(done);
  }

  boost::beast::websocket::close_reason close_reason() const { return ws_.reason(); }
  boost::beast::error_code last_error() const { return last_error_; }

 private:
  // Runs until `done` or the deadline; on the deadline the socket is closed and the pending
  // operation drained, so the client stays usable only for Drop().
  bool Run(bool& done, std::chrono::milliseconds timeout = kTimeout) {
    ioc_.restart();
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!done && std::chrono::steady_clock::now() < deadline) {
      ioc_.run_one_for(std::chrono::milliseconds(100));
      if (ioc_.stopped()) ioc_.restart();
    }
    if (!done) {
      Drop();
      ioc_.restart();
      ioc_.run_for(std::chrono::seconds(1));
    }
    return done;
  }

  boost::asio::io_context ioc_;
  Ws ws_;
  boost::beast::error_code last_error_;
};

using WsClient = BasicWsClient<boost::asio::ip::tcp::socket>;
using WssClient = BasicWsClient<boost::asio::ssl::stream<boost::asio::ip::tcp::socket>>;

}  // namespace drivegw::rest::test_support
