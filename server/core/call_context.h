// Who is calling, as the front end saw it; shared by the core and its per-stream objects.
#pragma once

#include <string>

namespace drivegw::server {

// principal is "anonymous" until authentication.
struct CallContext {
  std::string principal = "anonymous";
  std::string source_address;
  std::string transport;  // "grpc" or "rest"
};

}  // namespace drivegw::server
