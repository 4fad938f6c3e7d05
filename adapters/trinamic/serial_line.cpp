// SerialLine: the per-device registry and the line-wide rules (serial_line.h, decision 1471).
#include "adapters/trinamic/serial_line.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace drivegw::trinamic {
namespace {

struct Registry {
  std::mutex mu;
  std::map<std::string, std::weak_ptr<SerialLine>> lines;
};
Registry& TheRegistry() {
  static Registry* r = new Registry;  // never destroyed: lines may outlive static destruction
  return *r;
}

// One line per terminal, whichever path names it (a udev by-id link, a pty symlink).
std::string KeyOf(const std::string& device) {
  std::error_code ec;
  std::filesystem::path p = std::filesystem::canonical(device, ec);
  return ec ? device : p.string();
}

std::string DuplexName(transport::SerialConfig::Duplex d) {
  return d == transport::SerialConfig::Duplex::kHalfRs485 ? "RS-485" : "RS-232";
}

}  // namespace

std::string DescribeMember(const LineMember& m) {
  const std::string address = absl::StrCat("address ", std::to_string(m.address));
  return m.owner.empty() ? address : absl::StrCat(m.owner, " (", address, ")");
}

absl::StatusOr<std::shared_ptr<SerialLine>> SerialLine::Attach(
    const transport::SerialConfig& config, const LineMember& member) {
  const std::string key = KeyOf(config.device);
  Registry& r = TheRegistry();
  std::lock_guard lock(r.mu);
  if (auto it = r.lines.find(key); it != r.lines.end()) {
    if (std::shared_ptr<SerialLine> line = it->second.lock()) {
      std::lock_guard m(line->members_mu_);
      if (auto s = line->Admit(config, member); !s.ok()) return s;
      line->members_.push_back(member);
      return line;
    }
  }
  auto port = transport::SerialPort::Open(config);
  if (!port.ok()) return port.status();
  std::shared_ptr<SerialLine> line(new SerialLine(key, config, std::move(*port)));
  line->members_.push_back(member);
  r.lines[key] = line;
  return line;
}

SerialLine::SerialLine(std::string key, transport::SerialConfig config, transport::SerialPort port)
    : key_(std::move(key)), config_(config), configured_(std::move(config)) {
  port_.emplace(std::move(port));
}

SerialLine::~SerialLine() {
  Registry& r = TheRegistry();
  std::lock_guard lock(r.mu);
  if (auto it = r.lines.find(key_); it != r.lines.end() && it->second.expired()) {
    r.lines.erase(it);
  }
}

absl::Status SerialLine::Admit(const transport::SerialConfig& want,
                               const LineMember& member) const {
  const LineMember& first = members_.empty() ? member : members_.front();
  auto refuse = [&](const LineMember& other, const std::string& what) {
    return absl::InvalidArgumentError(absl::StrCat("trinamic serial line ", configured_.device,
                                                   ": ", DescribeMember(member), " ", what, " ",
                                                   DescribeMember(other)));
  };
  if (want.baud != configured_.baud) {
    return refuse(first, absl::StrCat("wants ", want.baud, " baud, the line runs at ",
                                      configured_.baud, " baud for"));
  }
  if (want.duplex != configured_.duplex) {
    return refuse(first, absl::StrCat("wants ", DuplexName(want.duplex), ", the line is ",
                                      DuplexName(configured_.duplex), " for"));
  }
  if (want.duplex == transport::SerialConfig::Duplex::kHalfRs485 &&
      want.turnaround != configured_.turnaround) {
    return refuse(
        first, absl::StrCat("wants a turnaround of ", want.turnaround.count(), " us, the line has ",
                            configured_.turnaround.count(), " us for"));
  }
  for (const LineMember& m : members_) {
    if (m.address == member.address) {
      return refuse(m, "has the unit address of");  // L273/L275: both PACKs would act on it
    }
    // §2.4, CT-50: under R9 a reply to RA is, byte for byte, a word for the PACK with address RA.
    if (member.response_address == m.address) {
      return refuse(m,
                    absl::StrCat("sends its replies to response address ",
                                 std::to_string(member.response_address), ", the unit address of"));
    }
    if (member.address == m.response_address) {
      return refuse(m, "has as unit address the response address of");
    }
  }
  return absl::OkStatus();
}

void SerialLine::Detach(uint8_t address) {
  std::lock_guard m(members_mu_);
  members_.erase(std::remove_if(members_.begin(), members_.end(),
                                [&](const LineMember& x) { return x.address == address; }),
                 members_.end());
}

absl::Status SerialLine::Open() {
  if (port_) return absl::OkStatus();
  auto port = transport::SerialPort::Open(config_);
  if (!port.ok()) return port.status();
  port_.emplace(std::move(*port));
  return absl::OkStatus();
}

void SerialLine::Close() { port_.reset(); }

absl::Status SerialLine::CheckRateChange(int baud, uint8_t requester) const {
  if (baud == config_.baud) return absl::OkStatus();
  const std::vector<std::string> others = Neighbours(requester);
  if (others.empty()) return absl::OkStatus();
  return absl::FailedPreconditionError(
      absl::StrCat("trinamic serial line ", config_.device, ": a rate change to ", baud,
                   " baud is refused while ", absl::StrJoin(others, ", "),
                   " share the line (a $40 reaches one PACK, the others stay at ", config_.baud,
                   " baud; G-40)"));
}

absl::Status SerialLine::SetBaud(int baud, uint8_t requester) {
  if (auto s = CheckRateChange(baud, requester); !s.ok()) return s;
  if (auto s = transport::ValidateBaud(baud); !s.ok()) return s;
  if (port_) {
    if (auto s = port_->SetBaud(baud); !s.ok()) return s;
  }
  config_.baud = baud;  // a reopened port starts at the new rate too
  return absl::OkStatus();
}

std::optional<LineMember> SerialLine::MemberWithResponseAddress(uint8_t ra, uint8_t self) const {
  std::lock_guard m(members_mu_);
  for (const LineMember& x : members_) {
    if (x.address != self && x.response_address == ra) return x;
  }
  return std::nullopt;
}

std::vector<std::string> SerialLine::Neighbours(uint8_t self) const {
  std::lock_guard m(members_mu_);
  std::vector<std::string> out;
  for (const LineMember& x : members_) {
    if (x.address != self) out.push_back(DescribeMember(x));
  }
  return out;
}

}  // namespace drivegw::trinamic
