// The HTTP/1.1 request parser as the gateway's sessions set it up, and the answer to a read the
// parser refused: one place for both, shared by server.cpp and the `http_request` fuzz target
// (decision 1496).
#pragma once

#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/system/error_code.hpp>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "server/rest/router.h"

namespace drivegw::rest {

// Request line plus headers; a longer head gets 431.
inline constexpr uint32_t kHeaderLimit = 16384;

using RequestParser = boost::beast::http::request_parser<boost::beast::http::string_body>;

// Sets the header limit and `body_limit` (RestOptions::body_limit) on a fresh parser.
void ConfigureRequestParser(RequestParser& parser, size_t body_limit);

// What the session answers before it closes when a read failed with `ec`: 413 (body above
// `body_limit`), 431 (head above kHeaderLimit) or 400 "malformed HTTP request: …" for any other
// parse error. nullopt for success, an incomplete message (partial_message: the peer went away)
// and transport errors, which close without an answer.
std::optional<HttpResponse> RejectionFor(const boost::system::error_code& ec, size_t body_limit);

}  // namespace drivegw::rest
