// DeviceModel: what a simulated device (e.g. a CiA 402 drive) plugs into the generic CANopen
// slave: its objects and hooks, a time step, and the slave's events. Every call runs on the
// node's owner thread (SlaveServer: its I/O thread, under its lock), so a model needs no locking
// of its own against the node (decision 1126).
#pragma once

#include <cstdint>

#include "absl/status/status.h"
#include "adapters/canopen/nmt.h"
#include "adapters/core/clock.h"

namespace drivegw::sim::canopen {

class SlaveNode;

class DeviceModel {
 public:
  virtual ~DeviceModel() = default;

  // Once, before the node boots: add the device's objects (2000h..9FFFh), their hooks and the
  // default PDO configuration (SlaveNode::ConfigureDefaultPdo). An error aborts the start.
  virtual absl::Status Configure(SlaveNode& node) {
    (void)node;
    return absl::OkStatus();
  }
  // The model's time advances by `dt` (> 0) before the node handles a frame or its timers, so
  // TPDOs sample values at the current instant.
  virtual void Tick(SlaveNode& node, Duration dt) {
    (void)node;
    (void)dt;
  }
  // RPDO `number` (1..4) has been written into the dictionary (for synchronous RPDOs: at the
  // SYNC that applied it). The objects' write hooks ran before.
  virtual void OnRpdoWritten(SlaveNode& node, uint16_t number) {
    (void)node;
    (void)number;
  }
  // Every NMT state change, including kBootUp (initialising) during resets.
  virtual void OnNmtChange(SlaveNode& node, drivegw::canopen::NmtState from,
                           drivegw::canopen::NmtState to) {
    (void)node;
    (void)from;
    (void)to;
  }
  // A communication error the node detected (CiA 301 §7.2.8.3.2.3 / decision 1130): `emcy_code`
  // 8130h heartbeat consumer time-out of node `producer`, 8140h bus-off recovered (producer 0).
  // Called after the EMCY, before the 1029h NMT reaction. A CiA 402 drive applies its 6007h
  // abort connection option here (decision 1483).
  virtual void OnCommunicationError(SlaveNode& node, uint16_t emcy_code, uint8_t producer) {
    (void)node;
    (void)emcy_code;
    (void)producer;
  }
  // NMT reset node or an injected reboot: objects 2000h..9FFFh are back at their defaults; the
  // model resets its own state (motion, faults) to power-on.
  virtual void OnResetApplication(SlaveNode& node) { (void)node; }
};

}  // namespace drivegw::sim::canopen
