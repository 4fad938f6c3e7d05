// Fuzz target for the parameter-set file importers (server/core/parameter_set_io.cpp, decision
// 011): byte 0 even = the rest is a JSON file (ParseParameterSetJson), odd = a CSV file
// (ParseParameterSetCsv). Invariants: no crash; errors are InvalidArgument naming a line
// ("line N..."); a file that parses, exported in its own format (ParameterSetToJson /
// ParameterSetToCsv) and imported again, gives the same set.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "server/core/parameter_set_io.h"

namespace {

using drivegw::storage::ParameterSet;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

void CheckError(const absl::Status& s) {
  Check(s.code() == absl::StatusCode::kInvalidArgument);
  Check(s.message().substr(0, 5) == "line ");
}

bool SameImport(const ParameterSet& a, const ParameterSet& b) {
  return a.name == b.name && a.family == b.family && a.model == b.model &&
         a.description == b.description && a.target_stored == b.target_stored &&
         a.values == b.values;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const bool csv = data[0] & 1;
  auto set = csv ? drivegw::server::ParseParameterSetCsv(text)
                 : drivegw::server::ParseParameterSetJson(text);
  if (!set.ok()) {
    CheckError(set.status());
    return 0;
  }
  auto again =
      csv ? drivegw::server::ParseParameterSetCsv(drivegw::server::ParameterSetToCsv(*set))
          : drivegw::server::ParseParameterSetJson(drivegw::server::ParameterSetToJson(*set));
  Check(again.ok());
  Check(SameImport(*set, *again));
  return 0;
}
