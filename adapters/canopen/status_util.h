// Status helpers shared by the CANopen master's files.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace drivegw::canopen {

// `status` with `prefix` in front of its message; code and payloads (the SDO abort code,
// decision 1104) kept.
inline absl::Status AnnotateStatus(const absl::Status& status, const std::string& prefix) {
  absl::Status out(status.code(), absl::StrCat(prefix, ": ", status.message()));
  status.ForEachPayload(
      [&](absl::string_view url, const absl::Cord& payload) { out.SetPayload(url, payload); });
  return out;
}

}  // namespace drivegw::canopen
