// RestServer with TLS in front of the REST tests' fake DriveService: NDJSON streams over HTTPS
// (chunked, and HTTP/1.0 ending with close_notify), the handshake deadline, a connection that
// never handshakes not blocking others, PEM the context refuses, and Stop with TLS connections.
#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "server/rest/server.h"
#include "tests/server/rest/fake_drive_service.h"
#include "tests/server/tls/test_pki.h"

namespace drivegw::rest {
namespace {

using testing::Curl;
using ::testing::HasSubstr;
using testing::Quote;
using testing::ReadFile;
using testing::TestPki;
using namespace std::chrono_literals;

// A TCP connection to 127.0.0.1:port that sends nothing.
class SilentClient {
 public:
  explicit SilentClient(uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0;
  }
  ~SilentClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  SilentClient(const SilentClient&) = delete;
  SilentClient& operator=(const SilentClient&) = delete;
  bool connected() const { return connected_; }

  // True once the server closed the connection (EOF or reset) within `timeout`.
  bool ClosedByServer(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    char buf[256];
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return true;  // 0: FIN; < 0: reset
    }
    return false;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

class RestTlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    pki_ = new TestPki();
    ASSERT_TRUE(pki_->MakeCa("ca", "drivegw test CA"));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "server", "localhost", /*server=*/true));
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }
  static std::string P(const std::string& file) { return pki_->Path(file); }

  static RestTls Tls() {
    return RestTls{ReadFile(P("server.pem")), ReadFile(P("server.key")), "", false};
  }

  void Start(std::chrono::seconds handshake_timeout = 10s) {
    RestOptions o;
    o.listen_address = "127.0.0.1";
    o.port = 0;
    o.channel = grpc_.InProcessChannel();
    o.tls = Tls();
    o.handshake_timeout = handshake_timeout;
    auto s = RestServer::Start(std::move(o));
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
  }

  static std::string Trust() { return "--cacert " + Quote(P("ca.pem")); }

  static TestPki* pki_;
  test_support::FakeGrpcServer grpc_;
  std::unique_ptr<RestServer> server_;
};
TestPki* RestTlsTest::pki_ = nullptr;

TEST_F(RestTlsTest, Watch_ChunkedStreamOverTls_AllLinesThenEnd) {
  ASSERT_NO_FATAL_FAILURE(Start());
  auto r = Curl(server_->port(), "/v1/drives:watch?names=x1", Trust() + " -N");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("HTTP 200"));
  size_t lines = 0;
  for (size_t at = r.output.find("\"name\""); at != std::string::npos;
       at = r.output.find("\"name\"", at + 1)) {
    ++lines;
  }
  EXPECT_EQ(lines, 3u) << r.output;  // the fake sends three statuses per name
}

// HTTP/1.0 has no chunking: the body ends with the connection, so the client must get a
// close_notify, not a bare FIN that could be a truncation attack. curl tolerates a bare FIN;
// Python's ssl module with suppress_ragged_eofs=False does not (SSLEOFError, exit 1).
TEST_F(RestTlsTest, Watch_Http10_BodyEndsWithCloseNotify) {
  ASSERT_NO_FATAL_FAILURE(Start());
  testing::WriteFile(pki_->dir() / "http10.py", R"(import socket, ssl, sys
ca, port, target = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ctx = ssl.create_default_context(cafile=ca)
s = ctx.wrap_socket(socket.create_connection(("127.0.0.1", port), timeout=20),
                    server_hostname="127.0.0.1", suppress_ragged_eofs=False)
s.sendall(("GET %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n" % target).encode())
body = b""
while True:
    chunk = s.recv(4096)
    if not chunk:
        break
    body += chunk
sys.stdout.write(body.decode())
)");
  auto r = testing::RunCommand("python3 " + Quote(P("http10.py")) + " " + Quote(P("ca.pem")) + " " +
                               std::to_string(server_->port()) + " '/v1/drives:watch?names=x1'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("HTTP/1.0 200"));
  EXPECT_THAT(r.output, HasSubstr("\"name\""));
}

TEST_F(RestTlsTest, SilentClient_ClosedAtHandshakeDeadline_OthersServed) {
  ASSERT_NO_FATAL_FAILURE(Start(/*handshake_timeout=*/1s));
  SilentClient silent(server_->port());
  ASSERT_TRUE(silent.connected());
  // Served while the silent connection waits for its handshake.
  auto r = Curl(server_->port(), "/v1/drives", Trust());
  EXPECT_THAT(r.output, HasSubstr("HTTP 200"));
  EXPECT_TRUE(silent.ClosedByServer(30s));
}

TEST_F(RestTlsTest, Start_PemTheContextRefuses_InvalidArgumentNamingField) {
  RestOptions o;
  o.listen_address = "127.0.0.1";
  o.port = 0;
  o.channel = grpc_.InProcessChannel();
  o.tls = Tls();
  o.tls->cert_chain_pem = "not a certificate";
  auto s = RestServer::Start(o);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr("rest.tls.cert"));
  o.tls = Tls();
  o.tls->key_pem = ReadFile(P("ca.key"));  // a key of another certificate
  s = RestServer::Start(o);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr("rest.tls.key"));
}

TEST_F(RestTlsTest, Stop_WithTlsConnectionsOpen_Prompt) {
  ASSERT_NO_FATAL_FAILURE(Start());
  SilentClient silent(server_->port());
  ASSERT_TRUE(silent.connected());
  auto r = Curl(server_->port(), "/v1/drives", Trust());
  EXPECT_THAT(r.output, HasSubstr("HTTP 200"));
  server_->Stop();  // must not wait for the silent client's handshake
  EXPECT_TRUE(silent.ClosedByServer(10s));
}

}  // namespace
}  // namespace drivegw::rest
