// CANopen service data objects (SDO): every frame of CiA 301 expedited/segmented transfer, the
// abort codes, and two pure state machines: SdoClientTransfer (one upload or download) and
// SdoServer (over an ObjectAccess). No I/O and no clock: the runtime feeds received frames, sends
// what comes back and calls Timeout() when its deadline passes.
// Source: CiA 301 v4.2.0 §7.2.4.3 (SDO protocols: initiate download/upload with n/e/s bits,
// download/upload segment with t/n/c bits, abort transfer; Figures 23-30), Table 22 (SDO abort
// codes). Block transfer (ccs 5/6) is not implemented: decision 1101.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::canopen {

inline constexpr size_t kSdoFrameSize = 8;     // every SDO frame has DLC 8 (§7.2.4.3)
inline constexpr size_t kSdoExpeditedMax = 4;  // data bytes 4..7 of an initiate frame
inline constexpr size_t kSdoSegmentMax = 7;    // data bytes 1..7 of a segment
// Runtime default for the SDO deadline per frame exchange (decision 1103).
inline constexpr std::chrono::milliseconds kSdoDefaultTimeout{1000};
// Upper bound of MasterOptions::sdo_retries / canopen.sdo_retries: beyond it a dead node holds its
// SDO channel for many time-outs while nothing gets better (decision 1481).
inline constexpr int kSdoMaxRetries = 10;
// Default limit of one transfer's size, client upload and server download (decision 1103).
inline constexpr size_t kSdoDefaultMaxSize = 64 * 1024;

// CiA 301 Table 22.
enum class SdoAbortCode : uint32_t {
  kToggleBit = 0x05030000,         // toggle bit not alternated
  kTimeout = 0x05040000,           // SDO protocol timed out
  kInvalidCommand = 0x05040001,    // client/server command specifier not valid or unknown
  kInvalidBlockSize = 0x05040002,  // block mode only
  kInvalidSequence = 0x05040003,   // block mode only
  kCrcError = 0x05040004,          // block mode only
  kOutOfMemory = 0x05040005,
  kUnsupportedAccess = 0x06010000,
  kWriteOnly = 0x06010001,  // attempt to read a write-only object
  kReadOnly = 0x06010002,   // attempt to write a read-only object
  kNoObject = 0x06020000,   // object does not exist in the object dictionary
  kNotMappable = 0x06040041,
  kPdoLength = 0x06040042,
  kParameterIncompatible = 0x06040043,
  kInternalIncompatible = 0x06040047,
  kHardwareError = 0x06060000,
  kLengthMismatch = 0x06070010,
  kLengthTooHigh = 0x06070012,
  kLengthTooLow = 0x06070013,
  kNoSubIndex = 0x06090011,
  kValueRange = 0x06090030,
  kValueTooHigh = 0x06090031,
  kValueTooLow = 0x06090032,
  kMaxLessThanMin = 0x06090036,
  kResourceUnavailable = 0x060A0023,
  kGeneral = 0x08000000,
  kDataTransfer = 0x08000020,
  kLocalControl = 0x08000021,
  kDeviceState = 0x08000022,
  kNoDictionary = 0x08000023,
  kNoData = 0x08000024,
};
// Every code of Table 22, in table order.
std::span<const SdoAbortCode> AllAbortCodes();
bool IsKnownAbortCode(uint32_t code);
// "value range of parameter exceeded"; "unknown abort code" for values outside Table 22.
std::string_view AbortCodeDescription(SdoAbortCode code);
// "SDO abort 0x06090030 value range of parameter exceeded".
std::string AbortCodeName(SdoAbortCode code);

// A status carrying `code`: message "<context>: SDO abort 0x.. <description>", payload with the
// code (AbortCodeOf reads it back). Codes map to absl codes (decision 1104): 0504 0000h
// DeadlineExceeded, 0602 0000h/0609 0011h NotFound, 0601 000xh PermissionDenied, 0609 003xh
// OutOfRange, 0607 00xxh/0604 004xh InvalidArgument, 0504 0005h/060A 0023h ResourceExhausted,
// 0800 002xh FailedPrecondition, others Aborted.
absl::Status SdoAbortStatus(SdoAbortCode code, std::string_view context);
// The code in a status built by SdoAbortStatus (nullopt for other statuses).
std::optional<SdoAbortCode> AbortCodeOf(const absl::Status& status);
// The code a server answers for a failed Read/Write: AbortCodeOf when present, else by absl
// code (decision 1104): NotFound 0602 0000h, PermissionDenied 0601 0000h, OutOfRange and
// InvalidArgument 0609 0030h, FailedPrecondition 0800 0022h, ResourceExhausted 0504 0005h,
// Unavailable 0800 0020h, anything else 0800 0000h.
SdoAbortCode AbortCodeForStatus(const absl::Status& status);

// ---------------------------------------------------------------------------------------------
// Frames. Command specifiers overlap between the directions, so decoding needs the direction.

enum class SdoDirection : uint8_t {
  kRequest,   // client → server, COB-ID 600h + n (ccs)
  kResponse,  // server → client, COB-ID 580h + n (scs)
};

enum class SdoCommand : uint8_t {
  kInitiateDownload,  // request ccs 1 / response scs 3
  kDownloadSegment,   // request ccs 0 / response scs 1
  kInitiateUpload,    // request ccs 2 / response scs 2
  kUploadSegment,     // request ccs 3 / response scs 0
  kAbort,             // cs 4, both directions
  kBlockUpload,       // request ccs 5 / response scs 6 (decoded only, decision 1101)
  kBlockDownload,     // request ccs 6 / response scs 5 (decoded only, decision 1101)
};
std::string_view SdoCommandName(SdoCommand command);  // "initiate_download", ...

// One decoded SDO frame. Which fields mean something depends on command and direction:
//  initiate download request / initiate upload response: index, sub, expedited, size_indicated,
//    and data (expedited: 4 - n bytes, or 4 without size indication) or size (segmented);
//  initiate download response / initiate upload request: index, sub;
//  download segment request / upload segment response: toggle, last (c), data (7 - n bytes);
//  download segment response / upload segment request: toggle;
//  abort: index, sub, abort_code;  block frames: index, sub of block initiates (raw otherwise).
struct SdoFrame {
  SdoCommand command = SdoCommand::kAbort;
  uint16_t index = 0;
  uint8_t sub = 0;
  bool expedited = false;       // e
  bool size_indicated = false;  // s
  uint32_t size = 0;            // segmented initiate with s = 1: the total byte count
  bool toggle = false;          // t
  bool last = false;            // c: no more segments
  uint32_t abort_code = 0;
  uint8_t data_size = 0;  // valid bytes in data (0..7)
  std::array<uint8_t, 7> data{};
  std::array<uint8_t, 8> raw{};  // the 8 wire bytes as decoded (block frames keep only these)

  std::span<const uint8_t> bytes() const { return {data.data(), data_size}; }
};

// Decodes exactly 8 bytes; reserved bits (x) are ignored. InvalidArgument for another size
// ("canopen sdo frame: 5 bytes, need 8") and for command specifier 7. A segmented initiate with
// e = 0, s = 0 (size unknown) and an expedited one with s = 0 (all 4 bytes) are accepted
// (decision 1102).
absl::StatusOr<SdoFrame> DecodeSdo(std::span<const uint8_t> bytes, SdoDirection direction);
// Encodes the meaningful fields with reserved bits 0; InvalidArgument for block commands (not
// generated), data_size above 4 (expedited) or 7 (segment), or an expedited frame without data
// and size indication.
absl::StatusOr<std::array<uint8_t, 8>> EncodeSdo(const SdoFrame& frame, SdoDirection direction);

// Builders for the frames the state machines send (and tests compare byte for byte).
SdoFrame InitiateDownloadExpedited(uint16_t index, uint8_t sub, std::span<const uint8_t> data);
SdoFrame InitiateDownloadSegmented(uint16_t index, uint8_t sub, uint32_t size);
SdoFrame InitiateDownloadResponse(uint16_t index, uint8_t sub);
SdoFrame DownloadSegment(bool toggle, std::span<const uint8_t> data, bool last);
SdoFrame DownloadSegmentResponse(bool toggle);
SdoFrame InitiateUploadRequest(uint16_t index, uint8_t sub);
SdoFrame InitiateUploadExpedited(uint16_t index, uint8_t sub, std::span<const uint8_t> data);
SdoFrame InitiateUploadSegmented(uint16_t index, uint8_t sub, uint32_t size);
SdoFrame UploadSegmentRequest(bool toggle);
SdoFrame UploadSegment(bool toggle, std::span<const uint8_t> data, bool last);
SdoFrame AbortFrame(uint16_t index, uint8_t sub, SdoAbortCode code);

// The COB-IDs of one SDO channel (default: 600h + n requests, 580h + n responses).
struct SdoChannel {
  uint8_t node = 1;                  // for messages only
  uint16_t request_id = 0x600 + 1;   // client → server
  uint16_t response_id = 0x580 + 1;  // server → client
  friend constexpr bool operator==(SdoChannel, SdoChannel) = default;
};
// The default server SDO channel of node 1..127.
absl::StatusOr<SdoChannel> DefaultSdoChannel(uint8_t node);
// An SDO frame as a CAN frame of the channel (DLC 8); EncodeSdo must accept `frame`.
absl::StatusOr<transport::CanFrame> ToCanFrame(const SdoFrame& frame, SdoDirection direction,
                                               const SdoChannel& channel);

// ---------------------------------------------------------------------------------------------
// Client: one transfer at a time on one channel.

enum class SdoTransferKind : uint8_t { kUpload, kDownload };

struct SdoStep {
  enum class Kind : uint8_t {
    kIgnored,  // not for this transfer (other COB-ID, DLC != 8, or the transfer is over)
    kSend,     // send `frame` and wait for the next response
    kDone,     // finished; `data` holds an upload's bytes
    kFailed,   // finished with `status`; send `frame` too when present (our abort)
  };
  Kind kind = Kind::kIgnored;
  std::optional<transport::CanFrame> frame;
  std::vector<uint8_t> data;
  absl::Status status;
};

class SdoClientTransfer {
 public:
  // Reads index:sub; a server announcing or sending more than `max_size` bytes is aborted with
  // 0504 0005h (out of memory).
  static SdoClientTransfer Upload(const SdoChannel& channel, uint16_t index, uint8_t sub,
                                  size_t max_size = kSdoDefaultMaxSize);
  // Writes `data`: expedited for 1..4 bytes, segmented with size indication otherwise (also for
  // 0 bytes, which expedited cannot express; decision 1102).
  static SdoClientTransfer Download(const SdoChannel& channel, uint16_t index, uint8_t sub,
                                    std::vector<uint8_t> data);

  // The first request (initiate upload / download). Called again after Timeout() or Cancel(), it
  // starts the same transfer over from its initiate, toggle 0 (the master's retry, decision 1481).
  transport::CanFrame Start();
  // A received frame. Protocol violations (wrong toggle 0503 0000h, unexpected command 0504
  // 0001h, index/sub echo mismatch 0604 0043h, size mismatch 0607 0010h) fail the transfer with
  // the abort frame to send; a server abort fails it without one. Failed statuses carry the code
  // (AbortCodeOf) and read "sdo upload 0x6041:00 node 5: SDO abort 0x06020000 object does not
  // exist in the object dictionary".
  SdoStep OnFrame(const transport::CanFrame& frame);
  // The runtime's deadline passed: Failed (DeadlineExceeded) with the 0504 0000h abort frame;
  // Ignored when the transfer is already over.
  SdoStep Timeout();
  // Ends the transfer with the given abort (e.g. the caller gave up): Failed with the frame.
  SdoStep Cancel(SdoAbortCode code);

  SdoTransferKind kind() const { return kind_; }
  uint16_t index() const { return index_; }
  uint8_t sub() const { return sub_; }
  bool finished() const { return state_ == State::kFinished; }
  bool awaiting_initiate() const { return state_ == State::kWaitInitiateResponse; }

 private:
  enum class State : uint8_t {
    kIdle,
    kWaitInitiateResponse,
    kWaitSegment,
    kFinished,
  };
  SdoClientTransfer(const SdoChannel& channel, SdoTransferKind kind, uint16_t index, uint8_t sub,
                    std::vector<uint8_t> data, size_t max_size);
  SdoStep Send(const SdoFrame& frame);
  SdoStep Fail(SdoAbortCode code, bool send_abort, std::string_view detail = {});
  SdoStep Finish(std::vector<uint8_t> data);
  SdoStep NextDownloadSegment();
  SdoStep OnUploadResponse(const SdoFrame& frame);
  SdoStep OnDownloadResponse(const SdoFrame& frame);
  std::string Context() const;

  SdoChannel channel_;
  SdoTransferKind kind_;
  uint16_t index_;
  uint8_t sub_;
  std::vector<uint8_t> data_;  // download: the bytes to send; upload: received so far
  size_t max_size_;
  State state_ = State::kIdle;
  bool toggle_ = false;
  size_t offset_ = 0;                 // download: bytes sent
  std::optional<uint32_t> expected_;  // upload: indicated size
  bool last_sent_ = false;            // download: the segment with c = 1 is out
};

// ---------------------------------------------------------------------------------------------
// Server.

// The object dictionary as the SDO server sees it. Errors: SdoAbortStatus(code, ...) to choose
// the abort code, or any status (mapped by AbortCodeForStatus).
class ObjectAccess {
 public:
  virtual ~ObjectAccess() = default;
  virtual absl::StatusOr<std::vector<uint8_t>> Read(uint16_t index, uint8_t sub) = 0;
  virtual absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) = 0;
};

// Expedited and segmented upload and download; block requests are aborted with 0504 0001h
// (decision 1101). A new initiate request abandons a transfer in progress (decision 1105).
class SdoServer {
 public:
  SdoServer(const SdoChannel& channel, ObjectAccess& objects,
            size_t max_download = kSdoDefaultMaxSize);

  // A frame from the bus: the response to send, or nullopt (other COB-ID, DLC != 8, RTR,
  // a client abort).
  std::optional<transport::CanFrame> OnFrame(const transport::CanFrame& frame);
  // The runtime's deadline for the client's next segment passed: the 0504 0000h abort frame
  // (and the transfer is dropped), or nullopt when idle.
  std::optional<transport::CanFrame> Timeout();
  bool busy() const { return state_ != State::kIdle; }

 private:
  enum class State : uint8_t { kIdle, kDownloading, kUploading };
  std::optional<transport::CanFrame> Respond(const SdoFrame& frame);
  std::optional<transport::CanFrame> Abort(uint16_t index, uint8_t sub, SdoAbortCode code);
  std::optional<transport::CanFrame> OnInitiateDownload(const SdoFrame& frame);
  std::optional<transport::CanFrame> OnDownloadSegment(const SdoFrame& frame);
  std::optional<transport::CanFrame> OnInitiateUpload(const SdoFrame& frame);
  std::optional<transport::CanFrame> OnUploadSegment(const SdoFrame& frame);

  SdoChannel channel_;
  ObjectAccess& objects_;
  size_t max_download_;
  State state_ = State::kIdle;
  uint16_t index_ = 0;
  uint8_t sub_ = 0;
  bool toggle_ = false;
  std::vector<uint8_t> buffer_;
  size_t offset_ = 0;                 // upload: bytes sent
  std::optional<uint32_t> expected_;  // download: indicated size
};

}  // namespace drivegw::canopen
