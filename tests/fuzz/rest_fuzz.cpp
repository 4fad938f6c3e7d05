// Fuzz target for the REST path-template parser and matcher (server/rest/path_template.h):
// arbitrary bytes as a template, as a request path against the API's templates, and through
// PercentDecode. Invariants: no crash; a template that parses matches its own rendering rules.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "server/rest/path_template.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using drivegw::rest::PathTemplate;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  static const PathTemplate kApi[] = {
      *PathTemplate::Parse("/v1/drives"),
      *PathTemplate::Parse("/v1/drives:watch"),
      // A literal custom verb on the collection, next to the {name=drives/*} verbs below.
      *PathTemplate::Parse("/v1/drives:moveCoordinated"),
      *PathTemplate::Parse("/v1/{name=drives/*}:moveAbsolute"),
      *PathTemplate::Parse("/v1/{name=drives/*}:sendNativeCommand"),
      *PathTemplate::Parse("/v1/{name=drives/*/commands/*}"),
      *PathTemplate::Parse("/v1/{name=drives/*}/parameters/{parameter_id}:write"),
      // ParameterSetService (decision 011): a collection verb next to {name=parameterSets/*}
      // verbs, a nested collection with a second variable, and a field path variable.
      *PathTemplate::Parse("/v1/parameterSets:import"),
      *PathTemplate::Parse("/v1/{name=parameterSets/*}:apply"),
      *PathTemplate::Parse("/v1/{name=parameterSets/*}/versions/{version}"),
      *PathTemplate::Parse("/v1/{parameter_set.name=parameterSets/*}"),
      *PathTemplate::Parse("/v1/{name=operations/*}"),
      *PathTemplate::Parse("/v1/families/{family}/parameterDefinitions"),
      *PathTemplate::Parse("/static/{path=**}"),
  };
  // As a request path ("/" in front so most inputs reach the segment matcher).
  const std::string path = "/" + std::string(input);
  for (const auto& t : kApi) {
    if (auto bindings = t.Match(path)) {
      if (bindings->size() != t.variables().size()) __builtin_trap();
    }
  }
  // As a template: if it parses, every variable covers segments inside the template.
  if (auto t = PathTemplate::Parse(input); t.ok()) {
    for (const auto& v : t->variables()) {
      if (v.first_segment >= v.end_segment || v.end_segment > t->segments().size()) {
        __builtin_trap();
      }
    }
    (void)t->Match(input);
    (void)t->Specificity();
  }
  (void)drivegw::rest::PercentDecode(input, size % 2 == 0, size % 3 == 0);
  return 0;
}
