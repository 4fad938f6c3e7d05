// Proto -> JSON for REST responses: the text protobuf's MessageToJsonString prints with
// always_print_primitive_fields and preserve_proto_field_names (decision 501 item 5), produced
// by a direct walk over the message for the field kinds the API's responses use, and by
// MessageToJsonString itself for anything else (decision 1332).
#pragma once

#include <string>

#include "absl/status/statusor.h"

namespace google::protobuf {
class Message;
}

namespace drivegw::rest {

// MessageToJsonString(msg, {always_print_primitive_fields, preserve_proto_field_names}), byte
// for byte.
absl::StatusOr<std::string> PrintJson(const google::protobuf::Message& msg);

// The direct walk alone: appends msg's JSON to *out and returns true, or returns false (out
// then holds a partial text) when msg holds something the walk leaves to protobuf: bytes, maps,
// oneofs, proto3 `optional`, well-known types other than Timestamp and the scalar wrappers,
// non-ASCII or escaped characters in strings, proto2. Exposed for tests.
bool AppendJsonDirect(const google::protobuf::Message& msg, std::string* out);

}  // namespace drivegw::rest
