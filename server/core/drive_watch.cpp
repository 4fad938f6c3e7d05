// DriveServiceCore::OpenWatch: WatchDrives as a non-blocking "next changed snapshots" source for
// the shared WatchTicker (issue 10, P5; decision 1341).
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/core/convert.h"
#include "server/core/drive_service.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

constexpr double kDefaultWatchRateHz = 20;
constexpr double kMaxWatchRateHz = 1000;

class DriveWatchSource final : public WatchSource {
 public:
  DriveWatchSource(std::vector<Drive*> watched, WatchSnapshots& snapshots,
                   std::chrono::steady_clock::duration period,
                   const std::atomic<bool>& shutting_down)
      : watched_(std::move(watched)),
        snapshots_(snapshots),
        period_(period),
        shutting_down_(shutting_down),
        last_(watched_.size()),
        last_seq_(watched_.size(), 0),
        sent_any_(watched_.size(), false) {}

  void Next(std::vector<SharedDriveStatus>& out) override {
    for (size_t i = 0; i < watched_.size(); ++i) {
      DriveStatus s = watched_[i]->GetStatus();
      if (sent_any_[i] && s.sequence == last_seq_[i]) continue;
      last_seq_[i] = s.sequence;
      // Converted once per snapshot for all streams; link counters at most a period old.
      WatchSnapshots::Snapshot snap = snapshots_.Get(
          *watched_[i], s, [&] { return StatusToProto(*watched_[i], s); }, period_);
      // Changed content only (decision 507): the key pointer first, the bytes when it differs.
      if (sent_any_[i] && (snap.key == last_[i] || *snap.key == *last_[i])) continue;
      last_[i] = std::move(snap.key);
      sent_any_[i] = true;
      out.push_back(std::move(snap.proto));
    }
  }

  bool Ended() const noexcept override { return shutting_down_.load(); }

 private:
  std::vector<Drive*> watched_;
  WatchSnapshots& snapshots_;
  std::chrono::steady_clock::duration period_;
  const std::atomic<bool>& shutting_down_;
  std::vector<std::shared_ptr<const std::string>> last_;
  std::vector<uint64_t> last_seq_;
  std::vector<bool> sent_any_;
};

}  // namespace

absl::StatusOr<DriveServiceCore::OpenedWatch> DriveServiceCore::OpenWatch(
    const v1::WatchDrivesRequest& r, const CallContext&) {
  double rate = r.max_rate_hz();
  if (!(rate >= 0)) return FieldError("max_rate_hz", absl::StrCat(rate, " must not be negative"));
  if (rate > kMaxWatchRateHz) {
    return FieldError("max_rate_hz", absl::StrCat(rate, " exceeds ", kMaxWatchRateHz),
                      absl::StatusCode::kOutOfRange);
  }
  if (rate == 0) rate = kDefaultWatchRateHz;
  std::vector<Drive*> watched;
  if (r.names().empty()) {
    for (const auto& d : drives_) watched.push_back(d.get());
  } else {
    for (int i = 0; i < r.names_size(); ++i) {
      auto d = Find(absl::StrCat("names[", i, "]"), r.names(i));
      if (!d.ok()) return d.status();
      watched.push_back(*d);
    }
  }
  if (shutting_down_.load()) return absl::UnavailableError("the gateway is shutting down");
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / rate));
  return OpenedWatch{
      std::make_unique<DriveWatchSource>(std::move(watched), *snapshots_, period, shutting_down_),
      period};
}

}  // namespace drivegw::server
