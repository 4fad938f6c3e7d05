// The seam between the DeviceNet stack and the LinMot application: what the stack hands over
// (consumed I/O messages, connection state, network coded errors) and what it asks for
// (produced images). The device implements it; stack tests use a fake.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace drivegw::sim::linmot_devicenet {

// Which I/O connection of the predefined set a message belongs to (§5.6 instances 2 and 4).
enum class IoConnection : uint8_t { kPoll, kCos };

enum class ConsumeOutcome : uint8_t {
  kRespond,          // answer with the produced image
  kResetController,  // 0x0F Reset Controller: no response, the drive restarts (seed line 984)
};

class IoApplication {
 public:
  virtual ~IoApplication() = default;
  // One complete consumed message of exactly the connection's consumed size (§12.4).
  virtual ConsumeOutcome Consume(IoConnection connection, std::span<const uint8_t> message) = 0;
  // The produced image of the connection (its produced size).
  virtual std::vector<uint8_t> Produce(IoConnection connection) = 0;
  // An I/O connection carrying master data is established (true) or was lost (false): D-15.
  virtual void SetIoConnected(bool connected) = 0;
  // A network condition the drive reports as a coded error (0x8101, 0x8143, 0x8148; §8.6).
  virtual void RaiseCodedError(uint16_t code) = 0;
  // Identity object Reset service (§5.11): the controller restarts like 0x0F.
  virtual void ResetController() = 0;
};

}  // namespace drivegw::sim::linmot_devicenet
