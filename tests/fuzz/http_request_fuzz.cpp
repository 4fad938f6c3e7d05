// Fuzz target for the HTTP/1.1 front end (gap 3, decision 1496): the input is the byte stream a
// client sends. It goes through Beast's request parser set up as the gateway's sessions set it
// (server/rest/request_reader.h: 16 KiB head, the 1 MiB default body limit), fed in one or two
// pieces the way reads arrive; a refused read gets the session's answer (RejectionFor); a
// complete request's Authorization header goes to Authenticator::FromBearer against a real
// token table. "@TOKEN@" in the header stands for the table's one live token, so the corpus
// reaches the accepting path too. Invariants: no crash; a refusal is 400, 413 or 431 with a JSON
// body; a complete request's body is within the limit; FromBearer is OK (the live token's
// principal) or UNAUTHENTICATED, and OK for exactly "Bearer <live token>".
#include <boost/asio/buffer.hpp>
#include <boost/beast/http/error.hpp>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "absl/strings/str_replace.h"
#include "server/auth/authenticator.h"
#include "server/rest/request_reader.h"
#include "server/rest/server.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"

namespace {

namespace http = boost::beast::http;
using drivegw::rest::kDefaultBodyLimit;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

// One SQLite token table for the whole run, with one live operator token.
struct Tokens {
  Tokens() {
    char tmpl[] = "/tmp/drivegw-http-fuzz-XXXXXX";
    Check(::mkdtemp(tmpl) != nullptr);
    dir = tmpl;
    auto opened = drivegw::storage::Db::Open(dir + "/tokens.db");
    Check(opened.ok());
    db = std::make_unique<drivegw::storage::Db>(*std::move(opened));
    Check(drivegw::storage::Migrate(*db).ok());
    repo = std::make_unique<drivegw::storage::TokenRepo>(*db);
    auto created = repo->Create("fuzz-operator", "operator");
    Check(created.ok());
    token = created->token;
    auth = std::make_unique<drivegw::auth::Authenticator>(
        drivegw::auth::AuthOptions{.enabled = true, .certificates = {}}, repo.get());
  }
  ~Tokens() {
    auth.reset();
    repo.reset();
    db.reset();
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  std::string dir;
  std::unique_ptr<drivegw::storage::Db> db;
  std::unique_ptr<drivegw::storage::TokenRepo> repo;
  std::unique_ptr<drivegw::auth::Authenticator> auth;
  std::string token;
};

Tokens& SharedTokens() {
  static Tokens tokens;
  return tokens;
}

// Feeds `bytes` to `parser` as a session's reads would: the first `split` bytes, then the rest,
// then the end of the stream. Returns the error that ended the read (none: a complete message).
boost::system::error_code Feed(drivegw::rest::RequestParser& parser, std::string_view bytes,
                               size_t split) {
  boost::system::error_code ec;
  std::string pending;
  for (std::string_view piece : {bytes.substr(0, split), bytes.substr(split)}) {
    pending.append(piece);
    while (!pending.empty() && !parser.is_done()) {
      const size_t used = parser.put(boost::asio::buffer(pending), ec);
      pending.erase(0, used);
      if (ec == http::error::need_more) {
        ec = {};
        break;  // wait for the next piece
      }
      if (ec) return ec;
      if (used == 0) break;
    }
    if (parser.is_done()) return ec;
  }
  parser.put_eof(ec);  // the client closed
  return ec;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  Tokens& tokens = SharedTokens();
  // The first byte picks where the stream is split in two reads.
  const std::string_view stream(reinterpret_cast<const char*>(data) + 1, size - 1);
  const size_t split = stream.empty() ? 0 : data[0] % (stream.size() + 1);
  drivegw::rest::RequestParser parser;
  drivegw::rest::ConfigureRequestParser(parser, kDefaultBodyLimit);
  const boost::system::error_code ec = Feed(parser, stream, split);
  if (ec || !parser.is_done()) {
    const auto rejection = drivegw::rest::RejectionFor(ec, kDefaultBodyLimit);
    if (rejection) {
      Check(rejection->status == 400 || rejection->status == 413 || rejection->status == 431);
      Check(!rejection->body.empty() && rejection->body.front() == '{');
    }
    return 0;
  }
  const auto& request = parser.get();
  Check(request.body().size() <= kDefaultBodyLimit);
  const auto field = request[http::field::authorization];
  const std::string authorization =
      absl::StrReplaceAll(std::string(field.data(), field.size()), {{"@TOKEN@", tokens.token}});
  const auto principal = tokens.auth->FromBearer(authorization);
  if (principal.ok()) {
    Check(principal->name == "fuzz-operator" && principal->via == "token");
    Check(principal->role == drivegw::auth::Role::kOperator);
  } else {
    Check(principal.status().code() == absl::StatusCode::kUnauthenticated);
    Check(authorization != "Bearer " + tokens.token);
    // A refusal never echoes the secret.
    // "dgw_" + 16 hex digits of id + "_" + the secret (storage/token_repo.h).
    const std::string secret = tokens.token.substr(4 + 16 + 1);
    Check(principal.status().message().find(secret) == absl::string_view::npos);
  }
  return 0;
}
