// Drive and wire metrics (issue 7 "Operations"; decision 021): a scrape-time collector over the
// configured drives (link state, the family sessions' exchange counters, STOBER SYNC timing) and
// the round-trip histograms fed through adapters/core/wire_observer.h. The only ops file that
// knows the families (like the composition root).
#pragma once

#include <memory>
#include <vector>

#include "adapters/core/drive.h"
#include "server/ops/metrics.h"

namespace drivegw::ops {

// Adds a collector reading `drives` at every scrape; returns its id (Registry::RemoveCollector).
int AddDriveCollector(Registry& registry, std::vector<std::shared_ptr<Drive>> drives);

// Routes wire::ObserveRoundTrip into drivegw_wire_round_trip_seconds{family,drive} of
// DefaultRegistry(). Idempotent.
void InstallRoundTripHistograms();

}  // namespace drivegw::ops
