// ConfigureRequestParser and RejectionFor: the parser limits and the refusal of a bad read
// (decision 1496).
#include "server/rest/request_reader.h"

#include <boost/beast/http/error.hpp>

#include "absl/strings/str_cat.h"

namespace drivegw::rest {
namespace {

namespace http = boost::beast::http;

constexpr int kInvalidArgument = 3;
constexpr int kResourceExhausted = 8;

}  // namespace

void ConfigureRequestParser(RequestParser& parser, size_t body_limit) {
  parser.body_limit(body_limit);
  parser.header_limit(kHeaderLimit);
}

std::optional<HttpResponse> RejectionFor(const boost::system::error_code& ec, size_t body_limit) {
  if (ec == http::error::body_limit) {
    return ErrorResponse(413, kResourceExhausted,
                         absl::StrCat("request body exceeds the limit of ", body_limit, " bytes"));
  }
  if (ec == http::error::header_limit) {
    return ErrorResponse(431, kResourceExhausted,
                         absl::StrCat("request header exceeds ", kHeaderLimit, " bytes"));
  }
  // Every Beast HTTP error shares one category; end_of_stream (a clean close between requests)
  // and partial_message (a close inside one) get no answer.
  if (ec && ec.category() == http::make_error_code(http::error::bad_target).category() &&
      ec != http::error::partial_message && ec != http::error::end_of_stream) {
    return ErrorResponse(400, kInvalidArgument,
                         absl::StrCat("malformed HTTP request: ", ec.message()));
  }
  return std::nullopt;
}

}  // namespace drivegw::rest
