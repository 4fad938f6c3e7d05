// The status line and header block of a whole response, written by the session without
// building a Beast message (decision 1365): the bytes Beast's serializer writes for the
// response<string_body> the session built before (Server, Content-Type, the extra headers,
// keep-alive, prepare_payload), so nothing a client sees changes.
#pragma once

#include <string>

#include "server/rest/router.h"

namespace drivegw::rest {

// Appends to `out` the head of `response` (its body excluded) for an HTTP `version` (10, 11)
// request, with "Connection" as Beast's keep_alive(`keep_alive`) sets it and Content-Length
// the body's size. Returns false, leaving `out` as it was, for a response whose head Beast must
// write itself: a status outside 100–999 or without a body by definition (1xx, 204, 304), or an
// extra header that the framing headers interact with (Connection, Content-Length,
// Transfer-Encoding).
bool AppendResponseHead(const HttpResponse& response, unsigned version, bool keep_alive,
                        std::string& out);

}  // namespace drivegw::rest
