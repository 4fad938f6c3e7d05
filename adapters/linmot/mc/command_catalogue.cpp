// The table of every LinMot MC motion command of linmot-mc.md §5 (IDs, parameter layouts,
// product availability from the MC22 overview, L793-1126).
#include <algorithm>
#include <array>

#include "adapters/linmot/mc/motion_command.h"

namespace drivegw::linmot::mc {
namespace {

using T = ParamType;
constexpr auto S16 = T::kSInt16;
constexpr auto U16 = T::kUInt16;
constexpr auto S32 = T::kSInt32;
constexpr auto U32 = T::kUInt32;

// Units (§0.4).
constexpr const char* kPos = "0.1 um";
constexpr const char* kVel = "1E-6 m/s";
constexpr const char* kAcc = "1E-5 m/s^2";
constexpr const char* kJerk = "1E-4 m/s^3";
constexpr const char* kSPos = "scaled by 1455h";  // 16-bit commands, D-14
constexpr const char* kSVel = "scaled by 1456h";
constexpr const char* kSAcc = "scaled by 1457h";
constexpr const char* kSJerk = "scaled by 1458h";
constexpr const char* kMa = "1 mA";
constexpr const char* kForce = "0.1 N";
constexpr const char* kIncr = "increments";
constexpr const char* kNone = "";

// Availability columns C1100 / C1250 / E1200 / E1400 (§5.0).
constexpr auto Y = Availability::kYes;
constexpr auto N = Availability::kNo;
constexpr auto F = Availability::kForceControlKey;
using Av = std::array<Availability, kProductCount>;
constexpr Av kAll{Y, Y, Y, Y};
constexpr Av kE12E14{N, N, Y, Y};      // ..11
constexpr Av kC1100Only{Y, N, N, N};   // 1...
constexpr Av kNotC1100{N, Y, Y, Y};    // .111
constexpr Av kC1250Only{N, Y, N, N};   // .1..
constexpr Av kE1200Only{N, N, Y, N};   // ..1.
constexpr Av kC1250E1400{N, Y, N, Y};  // .1.1 (VAJI, §5.17)
constexpr Av kNotE1200{Y, Y, N, Y};    // 11.1 (398, 399)
constexpr Av kForce4{F, F, F, F};      // FFFF (38x)
constexpr Av kForceC1250{N, F, N, N};  // .F.. (38A, 38B)

// ----- Recurring layouts (§5.0 table). -----
constexpr ParamSpec kNoParams[] = {{"", 0, U16, kNone}};  // placeholder; spans use size 0
// VA: position, maximal velocity, acceleration, deceleration.
constexpr ParamSpec kVaTarget[] = {{"target_position", 2, S32, kPos},
                                   {"maximal_velocity", 6, U32, kVel},
                                   {"acceleration", 10, U32, kAcc},
                                   {"deceleration", 14, U32, kAcc}};
constexpr ParamSpec kVaIncrement[] = {{"position_increment", 2, S32, kPos},
                                      {"maximal_velocity", 6, U32, kVel},
                                      {"acceleration", 10, U32, kAcc},
                                      {"deceleration", 14, U32, kAcc}};
constexpr ParamSpec kVaCaptured[] = {{"captured_position_increment", 2, S32, kPos},
                                     {"maximal_velocity", 6, U32, kVel},
                                     {"acceleration", 10, U32, kAcc},
                                     {"deceleration", 14, U32, kAcc}};
constexpr ParamSpec kV3[] = {{"maximal_velocity", 2, U32, kVel},
                             {"acceleration", 6, U32, kAcc},
                             {"deceleration", 10, U32, kAcc}};
constexpr ParamSpec kPTarget[] = {{"target_position", 2, S32, kPos}};
constexpr ParamSpec kPIncrement[] = {{"position_increment", 2, S32, kPos}};
constexpr ParamSpec kPvTarget[] = {{"target_position", 2, S32, kPos},
                                   {"maximal_velocity", 6, U32, kVel}};
constexpr ParamSpec kPvIncrement[] = {{"position_increment", 2, S32, kPos},
                                      {"maximal_velocity", 6, U32, kVel}};
constexpr ParamSpec kPvaTarget[] = {{"target_position", 2, S32, kPos},
                                    {"maximal_velocity", 6, U32, kVel},
                                    {"acceleration_deceleration", 10, U32, kAcc}};
constexpr ParamSpec kPvaIncrement[] = {{"position_increment", 2, S32, kPos},
                                       {"maximal_velocity", 6, U32, kVel},
                                       {"acceleration_deceleration", 10, U32, kAcc}};
constexpr ParamSpec kPvaTargetMaxCurr[] = {{"target_position", 2, S32, kPos},
                                           {"maximal_velocity", 6, U32, kVel},
                                           {"acceleration_deceleration", 10, U32, kAcc},
                                           {"demand_curr_limit", 14, U16, kMa}};
constexpr ParamSpec kS16Target[] = {{"target_position", 2, S16, kSPos},
                                    {"maximal_velocity", 4, U16, kSVel},
                                    {"acceleration", 6, U16, kSAcc},
                                    {"deceleration", 8, U16, kSAcc}};
constexpr ParamSpec kS16Increment[] = {{"position_increment", 2, S16, kSPos},
                                       {"maximal_velocity", 4, U16, kSVel},
                                       {"acceleration", 6, U16, kSAcc},
                                       {"deceleration", 8, U16, kSAcc}};
constexpr ParamSpec kS16PTarget[] = {{"target_position", 2, S16, kSPos}};
constexpr ParamSpec kS16PIncrement[] = {{"position_increment", 2, S16, kSPos}};
constexpr ParamSpec kSinTarget[] = {{"target_position", 2, S32, kPos},
                                    {"maximal_velocity", 6, U32, kVel},
                                    {"maximal_acceleration_deceleration", 10, U32, kAcc}};
constexpr ParamSpec kSinIncrement[] = {{"position_increment", 2, S32, kPos},
                                       {"maximal_velocity", 6, U32, kVel},
                                       {"maximal_acceleration_deceleration", 10, U32, kAcc}};
constexpr ParamSpec kBvajTarget[] = {{"target_position", 2, S32, kPos},
                                     {"maximal_velocity", 6, U32, kVel},
                                     {"maximal_acceleration_deceleration", 10, U32, kAcc},
                                     {"maximal_jerk", 14, U32, kJerk}};
constexpr ParamSpec kBvajIncrement[] = {{"position_increment", 2, S32, kPos},
                                        {"maximal_velocity", 6, U32, kVel},
                                        {"maximal_acceleration_deceleration", 10, U32, kAcc},
                                        {"maximal_jerk", 14, U32, kJerk}};
constexpr ParamSpec kVajTarget[] = {{"target_position", 2, S32, kPos},
                                    {"maximal_velocity", 6, U32, kVel},
                                    {"maximal_acceleration", 10, U32, kAcc},
                                    {"maximal_deceleration", 14, U32, kAcc},
                                    {"jerk", 18, U32, kJerk}};
constexpr ParamSpec kVajIncrement[] = {{"position_increment", 2, S32, kPos},
                                       {"maximal_velocity", 6, U32, kVel},
                                       {"maximal_acceleration", 10, U32, kAcc},
                                       {"maximal_deceleration", 14, U32, kAcc},
                                       {"jerk", 18, U32, kJerk}};

// ----- §5.1 system -----
constexpr ParamSpec kP001[] = {{"interface_control_word", 2, U16, kNone}};
constexpr ParamSpec kP002[] = {{"upid", 2, U16, kNone}, {"parameter_value", 4, S32, kNone}};
constexpr ParamSpec kP003[] = {{"bit_mask", 2, U16, kNone}, {"bit_value", 4, U16, kNone}};
constexpr ParamSpec kP005[] = {{"controller_set_selection", 2, U16, kNone}};
constexpr ParamSpec kP009[] = {{"home_position", 2, S32, kPos}};
// ----- §5.2 -----
constexpr ParamSpec kP017[] = {{"deceleration", 2, U32, kAcc}};
constexpr ParamSpec kP01E[] = {{"transition_event_position", 2, S32, kPos},
                               {"max_velocity_after_event", 6, U32, kVel},
                               {"acceleration_after_event", 10, U32, kAcc},
                               {"deceleration_after_event", 14, U32, kAcc}};
// ----- §5.4 streaming -----
constexpr ParamSpec kPStream[] = {{"position", 2, S32, kPos}};
constexpr ParamSpec kPvStream[] = {{"position", 2, S32, kPos}, {"velocity", 6, S32, kVel}};
constexpr ParamSpec kPvaStream[] = {
    {"position", 2, S32, kPos}, {"velocity", 6, S32, kVel}, {"acceleration", 10, S32, kAcc}};
// ----- §5.5 time curves -----
constexpr ParamSpec kCurveId[] = {{"curve_id", 2, U16, kNone}};
constexpr ParamSpec kP042[] = {{"curve_id", 2, U16, kNone}, {"target_position", 4, S32, kPos}};
constexpr ParamSpec kP043[] = {{"curve_id", 2, U16, kNone},
                               {"target_position", 4, S32, kPos},
                               {"curve_time", 8, U32, "10 us"}};
constexpr ParamSpec kP044[] = {{"curve_id", 2, U16, kNone},
                               {"curve_offset", 4, S32, kPos},
                               {"time_scale", 8, U16, "0.01 %"},
                               {"amplitude_scale", 10, S16, "0.1 %"}};
constexpr ParamSpec kP045[] = {{"curve_id", 2, U16, kNone},
                               {"curve_offset", 4, S32, kPos},
                               {"curve_time", 8, U32, "10 us"},
                               {"amplitude_scale", 12, S16, "0.1 %"}};
// ----- §5.6 curve RAM -----
constexpr ParamSpec kP050[] = {{"curve_id", 2, U16, kNone},
                               {"curve_start_address_offset", 4, U16, kNone}};
constexpr ParamSpec kP051[] = {
    {"curve_id", 2, U16, kNone}, {"offset_in_byte", 4, U16, kNone}, {"value", 6, S16, kNone}};
constexpr ParamSpec kP052[] = {
    {"curve_id", 2, U16, kNone}, {"offset_in_byte", 4, U16, kNone}, {"value", 6, S32, kNone}};
constexpr ParamSpec kP054[] = {{"curve_id", 2, U16, kNone},
                               {"offset_in_byte", 4, U16, kNone},
                               {"curve_point_value", 6, S32, kNone}};
constexpr ParamSpec kP055[] = {{"curve_id", 2, U16, kNone},
                               {"offset_in_byte", 4, U16, kNone},
                               {"curve_point_value_1", 6, S32, kNone},
                               {"curve_point_value_2", 10, S32, kNone}};
constexpr ParamSpec kP056[] = {{"curve_id", 2, U16, kNone},
                               {"offset_in_byte", 4, U16, kNone},
                               {"curve_point_value_1", 6, S32, kNone},
                               {"curve_point_value_2", 10, S32, kNone},
                               {"curve_point_value_3", 14, S32, kNone}};
// ----- §5.7 encoder cam, indexing -----
constexpr ParamSpec kP063[] = {
    {"curve_id", 2, U16, kNone}, {"length", 4, S32, kIncr}, {"stroke", 8, S32, kPos}};
constexpr ParamSpec kP069[] = {{"curve_id", 2, U16, kNone},
                               {"curve_start_delay_count", 4, U32, kIncr}};
constexpr ParamSpec kP06A[] = {{"curve_id", 2, U16, kNone},
                               {"curve_start_delay_count", 4, S32, kIncr},
                               {"target_position", 8, S32, kPos},
                               {"curve_length", 12, S32, kIncr}};
constexpr ParamSpec kP06D[] = {{"curve_id", 2, U16, kNone},
                               {"curve_start_delay_count", 4, S32, kIncr},
                               {"amplitude_scale", 8, S16, "0.1 %"},
                               {"curve_length_in_counts", 10, S32, kIncr}};
constexpr ParamSpec kP104[] = {{"counter_value", 2, S32, kIncr}};
constexpr ParamSpec kPCam0[] = {{"curve_id", 2, U16, kNone}, {"curve_start_count", 4, S32, kIncr}};
constexpr ParamSpec kPCam2[] = {{"curve_id", 2, U16, kNone},
                                {"curve_start_count", 4, S32, kIncr},
                                {"target_position", 8, S32, kPos}};
constexpr ParamSpec kPCam3[] = {{"curve_id", 2, U16, kNone},
                                {"curve_start_count", 4, S32, kIncr},
                                {"start_position", 8, S32, kPos},
                                {"target_position", 12, S32, kPos},
                                {"cam_length_in_counts", 16, S32, kIncr}};
constexpr ParamSpec kPCam4[] = {{"curve_id", 2, U16, kNone},
                                {"curve_start_count", 4, S32, kIncr},
                                {"target_position", 8, S32, kPos},
                                {"cam_length_in_counts", 12, S32, kIncr}};
constexpr ParamSpec kPCam5[] = {{"curve_id", 2, U16, kNone},
                                {"curve_start_count", 4, S32, kIncr},
                                {"amplitude_scale", 8, S16, "0.1 %"},
                                {"cam_length_in_counts", 10, S32, kIncr}};
constexpr ParamSpec kPCam8[] = {{"amplitude_scale", 2, S16, "0.1 %"},
                                {"cam_length_in_counts", 4, S32, kIncr}};
// ----- §5.8 16-bit -----
constexpr ParamSpec kP097[] = {{"deceleration", 2, U16, kSAcc}};
constexpr ParamSpec kP09E[] = {{"transition_event_position", 2, S16, kSPos},
                               {"max_velocity_after_event", 4, U16, kSVel},
                               {"acceleration_after_event", 6, U16, kSAcc},
                               {"deceleration_after_event", 8, U16, kSAcc}};
// ----- §5.10 -----
constexpr ParamSpec kP0CE[] = {{"maximal_velocity", 2, U32, kVel},
                               {"acceleration_deceleration", 6, U32, kAcc}};
// ----- §5.11 -----
constexpr ParamSpec kP0D1[] = {{"target_position", 2, S16, kSPos},
                               {"maximal_velocity", 4, U16, kSVel},
                               {"acceleration_deceleration", 6, U16, kSAcc}};
constexpr ParamSpec kP0D8[] = {{"angle", 2, U16, "360 deg/2^16"}, {"deceleration", 4, U32, kAcc}};
// ----- §5.12, §5.13 -----
constexpr ParamSpec kP0E9[] = {{"maximal_velocity", 2, U32, kVel},
                               {"maximal_acceleration_deceleration", 6, U32, kAcc}};
constexpr ParamSpec kP0F2[] = {{"target_position", 2, S16, kSPos},
                               {"maximal_velocity", 4, U16, kSVel},
                               {"maximal_acceleration_deceleration", 6, U16, kSAcc},
                               {"maximal_jerk", 8, U16, kSJerk}};
constexpr ParamSpec kP0F9[] = {{"maximal_velocity", 2, U32, kVel},
                               {"maximal_acceleration_deceleration", 6, U32, kAcc},
                               {"maximal_jerk", 10, U32, kJerk}};
// ----- §5.14 command table -----
constexpr ParamSpec kCmdTabId[] = {{"command_table_id", 2, U16, kNone}};
constexpr ParamSpec kP208[] = {{"command_table_id", 2, U16, kNone},
                               {"parameter_offset", 4, U16, kNone},
                               {"parameter_value", 6, S16, kNone}};
constexpr ParamSpec kP209[] = {{"command_table_id", 2, U16, kNone},
                               {"parameter_offset", 4, U16, kNone},
                               {"parameter_value", 6, S32, kNone}};
constexpr ParamSpec kP210[] = {{"time", 2, U32, "100 us"}};
constexpr ParamSpec kDemPosTrig[] = {{"dem_pos_trig_level", 2, S32, kPos}};
constexpr ParamSpec kActPosTrig[] = {{"act_pos_trig_level", 2, S32, kPos}};
constexpr ParamSpec kDiffPosTrig[] = {{"diff_pos_trig_level", 2, S32, kPos}};
constexpr ParamSpec kDemVelTrig[] = {{"dem_vel_trig_level", 2, S32, kVel}};
constexpr ParamSpec kActVelTrig[] = {{"act_vel_trig_level", 2, S32, kVel}};
constexpr ParamSpec kCurrTrig[] = {{"dem_curr_trig_level", 2, S16, kMa}};
constexpr ParamSpec kSetValue[] = {{"set_value", 2, S32, kNone}};
constexpr ParamSpec kAddValue[] = {{"add_value", 2, S32, kNone}};
constexpr ParamSpec kUpid[] = {{"upid", 2, U16, kNone}};
// IF: condition value (native unit, D-17), then the TRUE / FALSE entries.
constexpr ParamSpec kIf[] = {{"condition_value", 2, S32, kNone},
                             {"command_table_id_if_true", 6, U16, kNone},
                             {"command_table_id_if_false", 8, U16, kNone}};
constexpr ParamSpec kIfMasked[] = {{"bit_mask", 2, U16, kNone},
                                   {"condition_value", 4, U16, kNone},
                                   {"command_table_id_if_true", 6, U16, kNone},
                                   {"command_table_id_if_false", 8, U16, kNone}};
// ----- §5.15 winding -----
constexpr ParamSpec kP301[] = {{"revolution_counts_to_start", 2, S32, "rev"}};
constexpr ParamSpec kP311[] = {{"curve_id", 2, U16, kNone},
                               {"revolution_counts_to_start", 4, S32, "rev"}};
// ----- §5.16 force/current -----
constexpr ParamSpec kP380[] = {{"target_position", 2, S32, kPos},
                               {"maximal_velocity", 6, U32, kVel},
                               {"acceleration", 10, U32, kAcc},
                               {"force_limit", 14, S16, kForce}};
constexpr ParamSpec kP382[] = {{"target_force", 2, S16, kForce}};
constexpr ParamSpec kP383[] = {{"target_position", 2, S32, kPos},
                               {"maximal_velocity", 6, U32, kVel},
                               {"acceleration", 10, U32, kAcc},
                               {"force_limit", 14, S16, kForce},
                               {"target_force", 16, S16, kForce}};
constexpr ParamSpec kP388[] = {{"position_increment", 2, S32, kPos},
                               {"maximal_velocity", 6, U32, kVel},
                               {"acceleration", 10, U32, kAcc},
                               {"force_limit", 14, S16, kForce},
                               {"target_force", 16, S16, kForce}};
constexpr ParamSpec kP38A[] = {
    {"target_position", 2, S32, kPos}, {"maximal_velocity", 6, U32, kVel},
    {"acceleration", 10, U32, kAcc},   {"deceleration", 14, U32, kAcc},
    {"time_delay", 18, U16, "1 ms"},   {"capture_time", 20, U16, "1 ms"}};
constexpr ParamSpec kP38B[] = {{"capture_time", 2, U16, "1 ms"}};
constexpr ParamSpec kP390[] = {{"demand_current", 2, S32, kMa}};
constexpr ParamSpec kP398[] = {{"target_force_relative", 2, S16, "0.002 %"}};
constexpr ParamSpec kP399[] = {{"target_force_absolute", 2, S16, kForce}};

template <size_t N>
constexpr std::span<const ParamSpec> P(const ParamSpec (&a)[N]) {
  return std::span<const ParamSpec>(a, N);
}
constexpr std::span<const ParamSpec> kHeaderOnly = std::span<const ParamSpec>(kNoParams, 0);

// clang-format off
constexpr CommandSpec kCommands[] = {
  // §5.1 Master ID 00h — system commands (MC22 L1130-1202)
  {0x00, 0x0, "No Operation", kHeaderOnly, kAll},
  {0x00, 0x1, "Write Interface Control Word", P(kP001), kAll},
  {0x00, 0x2, "Write Live Parameter", P(kP002), kAll},
  {0x00, 0x3, "Write X4 Intf Outputs with Mask", P(kP003), kAll},
  {0x00, 0x5, "Select Position Controller Set", P(kP005), kAll},
  {0x00, 0x8, "Clear Event Evaluation", kHeaderOnly, kAll},
  {0x00, 0x9, "Master Homing", P(kP009), kAll},
  {0x00, 0xA, "Reset I Position Controller", kHeaderOnly, kAll},
  {0x00, 0xF, "Reset", kHeaderOnly, kAll},
  // §5.2 Master ID 01h — VAI (MC22 L1204-1380)
  {0x01, 0x0, "VAI Go To Pos", P(kVaTarget), kAll},
  {0x01, 0x1, "VAI Increment Dem Pos", P(kVaIncrement), kAll},
  {0x01, 0x2, "VAI Increment Target Pos", P(kVaIncrement), kAll},
  {0x01, 0x3, "VAI Go To Pos From Act Pos And Act Vel", P(kVaTarget), kAll},
  {0x01, 0x4, "VAI Go To Pos From Act Pos Starting With Dem Vel = 0", P(kVaTarget), kAll},
  {0x01, 0x5, "VAI Increment Act Pos", P(kVaIncrement), kAll},
  {0x01, 0x6, "VAI Increment Act Pos Starting With Dem Vel = 0", P(kVaIncrement), kAll},
  {0x01, 0x7, "VAI Stop", P(kP017), kAll},
  {0x01, 0x8, "VAI Go To Pos After Actual Command", P(kVaTarget), kAll},
  {0x01, 0x9, "VAI Go To Analog Pos", P(kV3), kAll},
  {0x01, 0xA, "VAI Go To Pos On Rising Trigger Event", P(kVaTarget), kAll},
  {0x01, 0xB, "VAI Increment Target Pos On Rising Trigger Event", P(kVaIncrement), kAll},
  {0x01, 0xC, "VAI Go To Pos On Falling Trigger Event", P(kVaTarget), kAll},
  {0x01, 0xD, "VAI Increment Target Pos On Falling Trigger Event", P(kVaIncrement), kAll},
  {0x01, 0xE, "VAI Change Motion Parameters On Positive Position Transition", P(kP01E), kAll},
  {0x01, 0xF, "VAI Change Motion Parameters On Negative Position Transition", P(kP01E), kAll},
  // §5.3 Master ID 02h — Predef VAI (MC22 L1382-1481)
  {0x02, 0x0, "Predef VAI Go To Pos", P(kPTarget), kAll},
  {0x02, 0x1, "Predef VAI Increment Dem Pos", P(kPIncrement), kAll},
  {0x02, 0x2, "Predef VAI Increment Target Pos", P(kPIncrement), kAll},
  {0x02, 0x3, "Predef VAI Go To Pos From Act Pos And Act Vel", P(kPTarget), kAll},
  {0x02, 0x4, "Predef VAI Go To Pos From Act Pos Starting With Dem Vel = 0", P(kPTarget), kAll},
  {0x02, 0x7, "Predef VAI Stop", kHeaderOnly, kAll},
  {0x02, 0x8, "Predef VAI Go To Pos After Actual Command", P(kPTarget), kAll},
  {0x02, 0xA, "Predef VAI Go To Pos On Rising Trigger Event", P(kPTarget), kAll},
  {0x02, 0xB, "Predef VAI Increment Target Pos On Rising Trigger Event", P(kPIncrement), kAll},
  {0x02, 0xC, "Predef VAI Go To Pos On Falling Trigger Event", P(kPTarget), kAll},
  // errata 27: the parameter is an increment
  {0x02, 0xD, "Predef VAI Increment Target Pos On Falling Trigger Event", P(kPIncrement), kAll},
  {0x02, 0xE, "Predef VAI Infinite Motion Positive Direction", kHeaderOnly, kAll},
  {0x02, 0xF, "Predef VAI Infinite Motion Negative Direction", kHeaderOnly, kAll},
  // §5.4 Master ID 03h — streaming (MC22 L1483-1556)
  {0x03, 0x0, "P Stream With Slave Generated Time Stamp", P(kPStream), kAll},
  {0x03, 0x1, "PV Stream With Slave Generated Time Stamp", P(kPvStream), kAll},
  {0x03, 0x2, "P Stream With Slave Generated Time Stamp and Configured Period Time", P(kPStream), kAll},
  {0x03, 0x3, "PV Stream With Slave Generated Time Stamp and Configured Period Time", P(kPvStream), kAll},
  {0x03, 0x4, "PVA Stream With Slave Generated Time Stamp", P(kPvaStream), kAll},
  // errata 4: a PVA stream
  {0x03, 0x5, "PVA Stream With Slave Generated Time Stamp and Configured Period Time", P(kPvaStream), kAll},
  {0x03, 0xA, "PVA Stream With Master Generated Time Stamp", P(kPvaStream), kC1250Only},
  {0x03, 0xF, "Stop Streaming", kHeaderOnly, kAll},
  // §5.5 Master ID 04h — time curves (MC22 L1558-1677)
  {0x04, 0x0, "Time Curve With Default Parameters", P(kCurveId), kAll},
  {0x04, 0x1, "Time Curve With Default Parameters From Act Pos", P(kCurveId), kAll},
  {0x04, 0x2, "Time Curve To Pos With Default Speed", P(kP042), kAll},
  {0x04, 0x3, "Time Curve To Pos With Adjustable Time", P(kP043), kAll},
  {0x04, 0x4, "Time Curve With Adjustable Offset, Time Scale & Amplitude Scale", P(kP044), kAll},
  {0x04, 0x5, "Time Curve With Adjustable Offset, Time & Amplitude Scale", P(kP045), kAll},
  {0x04, 0x6, "Time Curve With Adjustable Offset, Time & Amplitude Scale On Rising Trigger Event", P(kP045), kAll},
  {0x04, 0x7, "Time Curve With Adjustable Offset, Time & Amplitude Scale On Falling Trigger Event", P(kP045), kAll},
  {0x04, 0xA, "Time Curve To Pos With Default Speed On Rising Trigger Event", P(kP042), kAll},
  {0x04, 0xC, "Time Curve To Pos With Default Speed On Falling Trigger Event", P(kP042), kAll},
  {0x04, 0xE, "Time Curve To Pos With Adjustable Time On Rising Trigger Event", P(kP043), kAll},
  {0x04, 0xF, "Time Curve To Pos With Adjustable Time On Falling Trigger Event", P(kP043), kAll},
  // §5.6 Master ID 05h — curve modification in RAM (MC22 L1679-1741)
  {0x05, 0x0, "Modify Curve Start Address in RAM", P(kP050), kE12E14},
  {0x05, 0x1, "Modify Curve Info Block 16 Bit Value in RAM", P(kP051), kE12E14},
  {0x05, 0x2, "Modify Curve Info Block 32 Bit Value in RAM", P(kP052), kE12E14},
  {0x05, 0x4, "Modify Curve Data Block 32 Bit Value in RAM", P(kP054), kE12E14},
  {0x05, 0x5, "Modify Curve Data Block 64 Bit Value in RAM", P(kP055), kE12E14},
  {0x05, 0x6, "Modify Curve Data Block 96 Bit Value in RAM", P(kP056), kE12E14},
  // §5.7 Master ID 06h — encoder cam (MC22 L1743-1829)
  {0x06, 0x0, "Reset and disable CAM motion", kHeaderOnly, kE12E14},
  {0x06, 0x1, "Enable CAM Motion on next Z", kHeaderOnly, kE12E14},
  {0x06, 0x3, "Start Encoder Cam From Actual Count and Pos", P(kP063), kAll},
  {0x06, 0x4, "Setup Encoder CAM from Actual Counts With Delay Counts", kHeaderOnly, kE12E14, false},
  {0x06, 0x9, "Setup Encoder Cam On Rising Trigger Event With Delay Counts", P(kP069), kE12E14},
  {0x06, 0xA, "Setup Encoder Cam On Rising Trigger Event With Delay Counts, Target Pos and Length", P(kP06A), kE12E14},
  {0x06, 0xB, "Setup Encoder Cam On Falling Trigger Event With Delay Counts", P(kP069), kE12E14},
  {0x06, 0xC, "Setup Encoder Cam On Falling Trigger Event With Delay Counts, Target Pos and Length", P(kP06A), kE12E14},
  {0x06, 0xD, "Setup Encoder Cam On Rising Trigger Event With Delay Counts, Amplitude scale and Length", P(kP06D), kE12E14},
  {0x06, 0xE, "Setup Encoder Cam On Falling Trigger Event With Delay Counts, Amplitude scale and Length", P(kP06D), kE12E14},
  // §5.7 Master ID 07h — position indexing (MC22 L1831-1869)
  {0x07, 0x0, "Start VAI Encoder Position Indexing", P(kVaTarget), kAll},
  {0x07, 0x1, "Start Predef VAI Encoder Position Indexing", P(kPTarget), kAll},
  {0x07, 0x2, "Start Encoder Position Indexing with VA-Filters", kHeaderOnly, kE12E14, false},
  {0x07, 0xE, "Stop Position Indexing and VAI Go To Pos", P(kVaTarget), kAll},
  {0x07, 0xF, "Stop Position Indexing and Predef VAI Go To Pos", P(kPTarget), kAll},
  // §5.8 Master ID 09h — 16-bit VAI (MC22 L1871-2037)
  {0x09, 0x0, "VAI 16 Bit Go To Pos", P(kS16Target), kAll},
  {0x09, 0x1, "VAI 16 Bit Increment Dem Pos", P(kS16Increment), kAll},
  {0x09, 0x2, "VAI 16 Bit Increment Target Pos", P(kS16Increment), kAll},
  {0x09, 0x3, "VAI 16 Bit Go To Pos From Act Pos And Act Vel", P(kS16Target), kAll},
  {0x09, 0x4, "VAI 16 Bit Go To Pos From Act Pos Starting With Dem Vel = 0", P(kS16Target), kAll},
  {0x09, 0x5, "VAI 16 Bit Increment Act Pos", P(kS16Increment), kAll},
  {0x09, 0x6, "VAI 16 Bit Increment Act Pos Starting With Dem Vel = 0", P(kS16Increment), kAll},
  {0x09, 0x7, "VAI 16 Bit Stop", P(kP097), kAll},
  {0x09, 0x8, "VAI 16 Bit Go To Pos After Actual Command", P(kS16Target), kAll},
  {0x09, 0xA, "VAI 16 Bit Go To Pos On Rising Trigger Event", P(kS16Target), kAll},
  {0x09, 0xB, "VAI 16 Bit Increment Target Pos On Rising Trigger Event", P(kS16Increment), kAll},
  {0x09, 0xC, "VAI 16 Bit Go To Pos On Falling Trigger Event", P(kS16Target), kAll},
  {0x09, 0xD, "VAI 16 Bit Increment Target Pos On Falling Trigger Event", P(kS16Increment), kAll},
  {0x09, 0xE, "VAI 16 Bit Change Motion Parameters On Positive Position Transition", P(kP09E), kAll},
  {0x09, 0xF, "VAI 16 Bit Change Motion Parameters On Negative Position Transition", P(kP09E), kAll},
  // §5.8 Master ID 0Ah — Predef 16-bit VAI (MC22 L2039-2126)
  {0x0A, 0x0, "Predef VAI 16 Bit Go To Pos", P(kS16PTarget), kAll},
  {0x0A, 0x1, "Predef VAI 16 Bit Increment Dem Pos", P(kS16PIncrement), kAll},
  {0x0A, 0x2, "Predef VAI 16 Bit Increment Target Pos", P(kS16PIncrement), kAll},
  {0x0A, 0x3, "Predef VAI 16 Bit Go To Pos From Act Pos And Act Vel", P(kS16PTarget), kAll},
  {0x0A, 0x4, "Predef VAI 16 Bit Go To Pos From Act Pos Starting With Dem Vel = 0", P(kS16PTarget), kAll},
  {0x0A, 0x7, "Predef VAI 16 Bit Stop", kHeaderOnly, kAll},
  {0x0A, 0x8, "Predef VAI 16 Bit Go To Pos After Actual Command", P(kS16PTarget), kAll},
  {0x0A, 0xA, "Predef VAI 16 Bit Go To Pos On Rising Trigger Event", P(kS16PTarget), kAll},
  {0x0A, 0xB, "Predef VAI 16 Bit Increment Target Pos On Rising Trigger Event", P(kS16PIncrement), kAll},
  {0x0A, 0xC, "Predef VAI 16 Bit Go To Pos On Falling Trigger Event", P(kS16PTarget), kAll},  // D-15
  {0x0A, 0xD, "Predef VAI 16 Bit Increment Target Pos On Falling Trigger Event", P(kS16PIncrement), kAll},
  // §5.9 Master ID 0Bh — VAI Predef Acc (MC22 L2128-2216)
  {0x0B, 0x0, "VAI Predef Acc Go To Pos", P(kPvTarget), kE12E14},
  {0x0B, 0x1, "VAI Predef Acc Increment Dem Pos", P(kPvIncrement), kE12E14},
  {0x0B, 0x2, "VAI Predef Acc Increment Target Pos", P(kPvIncrement), kE12E14},
  {0x0B, 0x3, "VAI Predef Acc Go To Pos From Act Pos And Act Vel", P(kPvTarget), kE12E14},
  {0x0B, 0x4, "VAI Predef Acc Go To Pos From Act Pos Starting With Dem Vel = 0", P(kPvTarget), kE12E14},
  {0x0B, 0x8, "VAI Predef Acc Go To Pos After Actual Command", P(kPvTarget), kE12E14},
  {0x0B, 0xA, "VAI Predef Acc Go To Pos On Rising Trigger Event", P(kPvTarget), kE12E14},
  {0x0B, 0xB, "VAI Predef Acc Increment Target Pos On Rising Trigger Event", P(kPvIncrement), kE12E14},
  {0x0B, 0xC, "VAI Predef Acc Go To Pos On Falling Trigger Event", P(kPvTarget), kE12E14},
  {0x0B, 0xD, "VAI Predef Acc Increment Target Pos On Falling Trigger Event", P(kPvIncrement), kE12E14},
  // §5.10 Master ID 0Ch — VAI Dec=Acc (MC22 L2218-2369)
  {0x0C, 0x0, "VAI Dec=Acc Go To Pos", P(kPvaTarget), kAll},
  {0x0C, 0x1, "VAI Dec=Acc Increment Dem Pos", P(kPvaIncrement), kAll},
  {0x0C, 0x2, "VAI Dec=Acc Increment Target Pos", P(kPvaIncrement), kAll},
  {0x0C, 0x3, "VAI Dec=Acc Go To Pos From Act Pos And Act Vel", P(kPvaTarget), kAll},
  {0x0C, 0x4, "VAI Dec=Acc Go To Pos From Act Pos Starting With Dem Vel = 0", P(kPvaTarget), kAll},
  {0x0C, 0x5, "VAI Dec=Acc Go To Pos With Max Curr", P(kPvaTargetMaxCurr), kAll},
  {0x0C, 0x6, "VAI Dec=Acc Go To Pos From Act Pos And Vel With Max Curr", P(kPvaTargetMaxCurr), kAll},
  {0x0C, 0x7, "VAI Dec=Acc Go To Pos From Act Pos And Vel = 0 With Max Curr", P(kPvaTargetMaxCurr), kAll},  // D-16
  {0x0C, 0x8, "VAI Dec=Acc Go To Pos After Actual Command", P(kPvaTarget), kAll},
  {0x0C, 0xA, "VAI Dec=Acc Go To Pos On Rising Trigger Event", P(kPvaTarget), kAll},
  {0x0C, 0xB, "VAI Dec=Acc Increment Target Pos On Rising Trigger Event", P(kPvaIncrement), kAll},
  {0x0C, 0xC, "VAI Dec=Acc Go To Pos On Falling Trigger Event", P(kPvaTarget), kAll},
  {0x0C, 0xD, "VAI Dec=Acc Increment Target Pos On Falling Trigger Event", P(kPvaIncrement), kAll},
  {0x0C, 0xE, "VAI Dec=Acc Infinite Motion Positive Direction", P(kP0CE), kAll},
  {0x0C, 0xF, "VAI Dec=Acc Infinite Motion Negative Direction", P(kP0CE), kAll},
  // §5.11 Master ID 0Dh — VAI variants (MC22 L2371-2489)
  {0x0D, 0x0, "VAI Increment Captured Pos", P(kVaCaptured), kAll},
  {0x0D, 0x1, "VAI 16 Bit Dec=Acc Go To Pos", P(kP0D1), kAll},
  {0x0D, 0x2, "Predef VAI Increment Act Pos by Cmd Tab Var1", kHeaderOnly, kC1100Only},
  {0x0D, 0x4, "VAI Go To Cmd Tab Var1 Pos", P(kV3), kAll},
  {0x0D, 0x5, "VAI Go To Cmd Tab Var2 Pos", P(kV3), kAll},
  {0x0D, 0x6, "VAI Go To Cmd Tab Var1 Pos From Act Pos And Act Vel", P(kV3), kAll},
  {0x0D, 0x7, "VAI Go To Cmd Tab Var2 Pos From Act Pos And Act Vel", P(kV3), kAll},
  {0x0D, 0x8, "VAI Stop at Angle", P(kP0D8), kNotC1100},
  {0x0D, 0x9, "VAI Increment Act Pos Starting With Dem Vel = 0 Reset I-Contr", P(kVaIncrement), kAll},
  // errata 5: rise/fall as in the detailed sections
  {0x0D, 0xC, "VAI Start Trig Rise Config VAI Command (incremental)", kHeaderOnly, kAll},
  {0x0D, 0xD, "VAI Start Trig Fall Config VAI Command (incremental)", kHeaderOnly, kAll},
  {0x0D, 0xE, "VAI Start Trig Rise Config VAI Command", kHeaderOnly, kAll},
  {0x0D, 0xF, "VAI Start Trig Fall Config VAI Command", kHeaderOnly, kAll},
  // §5.12 Master ID 0Eh — Sine VA (MC22 L2491-2590)
  {0x0E, 0x0, "Sin VA Go To Pos", P(kSinTarget), kAll},
  {0x0E, 0x1, "Sin VA Increment Demand Pos", P(kSinIncrement), kAll},
  {0x0E, 0x4, "Sin VA Go To Pos From Actual Pos", P(kSinTarget), kAll},
  {0x0E, 0x6, "Sin VA Increment Actual Pos", P(kSinIncrement), kAll},
  {0x0E, 0x8, "Sin VA Go To Pos After Actual Command", P(kSinTarget), kAll},
  {0x0E, 0x9, "Sin VA Go To Analog Pos", P(kP0E9), kAll},
  {0x0E, 0xA, "Sin VA Go To Pos On Rising Trigger Event", P(kSinTarget), kAll},
  {0x0E, 0xB, "Sin VA Increment Demand Pos On Rising Trigger Event", P(kSinIncrement), kAll},
  {0x0E, 0xC, "Sin VA Go To Pos On Falling Trigger Event", P(kSinTarget), kAll},
  {0x0E, 0xD, "Sin VA Increment Demand Pos On Falling Trigger Event", P(kSinIncrement), kAll},
  // §5.13 Master ID 0Fh — Bestehorn VAJ (MC22 L2592-2730)
  {0x0F, 0x0, "Bestehorn VAJ Go To Pos", P(kBvajTarget), kAll},
  {0x0F, 0x1, "Bestehorn VAJ Increment Demand Pos", P(kBvajIncrement), kAll},
  {0x0F, 0x2, "Bestehorn VAJ 16 Bit Go To Pos", P(kP0F2), kC1100Only},
  {0x0F, 0x4, "Bestehorn VAJ Go To Pos From Actual Pos", P(kBvajTarget), kAll},
  {0x0F, 0x6, "Bestehorn VAJ Increment Actual Pos", P(kBvajIncrement), kAll},
  {0x0F, 0x8, "Bestehorn VAJ Go To Pos After Actual Command", P(kBvajTarget), kAll},
  {0x0F, 0x9, "Bestehorn VAJ Go To Analog Pos", P(kP0F9), kAll},
  {0x0F, 0xA, "Bestehorn VAJ Go To Pos On Rising Trigger Event", P(kBvajTarget), kAll},
  {0x0F, 0xB, "Bestehorn VAJ Increment Demand Pos On Rising Trigger Event", P(kBvajIncrement), kAll},
  {0x0F, 0xC, "Bestehorn VAJ Go To Pos On Falling Trigger Event", P(kBvajTarget), kAll},
  {0x0F, 0xD, "Bestehorn VAJ Increment Demand Pos On Falling Trigger Event", P(kBvajIncrement), kAll},
  // §5.7 Master ID 10h — encoder cam (MC22 L2732-2759)
  {0x10, 0x0, "Encoder CAM Enable", kHeaderOnly, kE12E14},
  {0x10, 0x1, "Encoder CAM Disable", kHeaderOnly, kE12E14},
  {0x10, 0x2, "Encoder CAM Go To Sync Pos", kHeaderOnly, kE12E14},
  {0x10, 0x4, "Encoder CAM Set Value", P(kP104), kE12E14},
  // §5.7 Master IDs 11h, 12h — encoder cam 1 / 2 (MC22 L2761-2848)
  {0x11, 0x0, "Encoder Cam 1 Define Curve With Default Parameters", P(kPCam0), kE12E14},
  {0x11, 0x1, "Encoder Cam 1 Define Curve From Act Pos", P(kPCam0), kE12E14},
  {0x11, 0x2, "Encoder Cam 1 Define Curve To Pos", P(kPCam2), kE12E14},
  {0x11, 0x3, "Encoder Cam 1 Define Curve From Pos To Pos In Counts", P(kPCam3), kE12E14},
  {0x11, 0x4, "Encoder Cam 1 Define Curve To Pos In Counts", P(kPCam4), kE12E14},
  {0x11, 0x5, "Encoder Cam 1 Define Curve With Amplitude Scale In Counts", P(kPCam5), kE12E14},
  {0x11, 0x6, "Encoder Cam 1 Enable", kHeaderOnly, kE12E14},
  {0x11, 0x7, "Encoder Cam 1 Disable", kHeaderOnly, kE12E14},
  {0x11, 0x8, "Encoder Cam 1 Change Amplitude Scale and Length", P(kPCam8), kE12E14},
  {0x12, 0x0, "Encoder Cam 2 Define Curve With Default Parameters", P(kPCam0), kE12E14},
  {0x12, 0x1, "Encoder Cam 2 Define Curve From Act Pos", P(kPCam0), kE12E14},
  {0x12, 0x2, "Encoder Cam 2 Define Curve To Pos", P(kPCam2), kE12E14},
  {0x12, 0x3, "Encoder Cam 2 Define Curve From Pos To Pos In Counts", P(kPCam3), kE12E14},
  {0x12, 0x4, "Encoder Cam 2 Define Curve To Pos In Counts", P(kPCam4), kE12E14},
  {0x12, 0x5, "Encoder Cam 2 Define Curve With Amplitude Scale In Counts", P(kPCam5), kE12E14},
  {0x12, 0x6, "Encoder Cam 2 Enable", kHeaderOnly, kE12E14},
  {0x12, 0x7, "Encoder Cam 2 Disable", kHeaderOnly, kE12E14},
  {0x12, 0x8, "Encoder Cam 2 Change Amplitude Scale and Length", P(kPCam8), kE12E14},
  // §5.14 Master ID 20h — command table (MC22 L2850-2892)
  {0x20, 0x0, "Start Command Table Command", P(kCmdTabId), kAll},
  {0x20, 0x1, "Start Command Table Command On Rising Trigger Event", P(kCmdTabId), kAll},
  {0x20, 0x2, "Start Command Table Command On Falling Trigger Event", P(kCmdTabId), kAll},
  {0x20, 0x8, "Modify Command Table 16 bit Parameter in RAM", P(kP208), kNotC1100},
  {0x20, 0x9, "Modify Command Table 32 bit Parameter in RAM", P(kP209), kNotC1100},
  // §5.14 Master ID 21h — waits (MC22 L2894-2928, 1024-1025)
  {0x21, 0x0, "Wait Time", P(kP210), kAll},
  {0x21, 0x1, "Wait Until Motion Finished", kHeaderOnly, kAll},
  {0x21, 0x2, "Wait Until In Target Position", kHeaderOnly, kAll},
  {0x21, 0x3, "Wait Until Rising Trigger Event", kHeaderOnly, kAll},
  {0x21, 0x4, "Wait Until Falling Trigger Event", kHeaderOnly, kAll},
  {0x21, 0x8, "Wait Time Defined With Cmd Table Var 1", kHeaderOnly, kAll, false},
  {0x21, 0x9, "Wait Time Defined With Cmd Table Var 2", kHeaderOnly, kAll, false},
  // §5.14 Master ID 22h — wait until (MC22 L2930-3040)
  {0x22, 0x0, "Wait Until Demand Position Greater Than", P(kDemPosTrig), kAll},
  {0x22, 0x1, "Wait Until Demand Position Less Than", P(kDemPosTrig), kAll},
  {0x22, 0x2, "Wait Until Actual Position Greater Than", P(kActPosTrig), kAll},
  {0x22, 0x3, "Wait Until Actual Position Less Than", P(kActPosTrig), kAll},
  {0x22, 0x4, "Wait Until Difference Position Greater Than", P(kDiffPosTrig), kAll},
  {0x22, 0x5, "Wait Until Difference Position Less Than", P(kDiffPosTrig), kAll},
  {0x22, 0x6, "Wait Until Difference Position Unsigned Greater Than", P(kDiffPosTrig), kAll},
  {0x22, 0x7, "Wait Until Difference Position Unsigned Less Than", P(kDiffPosTrig), kAll},
  {0x22, 0x8, "Wait Until Demand Velocity Greater Than", P(kDemVelTrig), kAll},
  {0x22, 0x9, "Wait Until Demand Velocity Less Than", P(kDemVelTrig), kAll},
  {0x22, 0xA, "Wait Until Actual Velocity Greater Than", P(kActVelTrig), kAll},
  {0x22, 0xB, "Wait Until Actual Velocity Less Than", P(kActVelTrig), kAll},
  {0x22, 0xE, "Wait Until Current Greater Than", P(kCurrTrig), kAll},
  {0x22, 0xF, "Wait Until Current Less Than", P(kCurrTrig), kAll},
  // §5.14 Master ID 24h — command table variables (MC22 L3042-3112)
  {0x24, 0x0, "Set Cmd Table Var 1 To", P(kSetValue), kAll},
  {0x24, 0x1, "Add To Cmd Table Var 1", P(kAddValue), kAll},
  {0x24, 0x2, "Set Cmd Table Var 2 To", P(kSetValue), kAll},
  {0x24, 0x3, "Add To Cmd Table Var 2", P(kAddValue), kAll},
  {0x24, 0x8, "Write Cmd Table Var 1 To UPID RAM value", P(kUpid), kAll},
  {0x24, 0x9, "Write Cmd Table Var 2 To UPID RAM value", P(kUpid), kAll},
  {0x24, 0xC, "Write UPID RAM Value To Cmd Table Var 1", P(kUpid), kAll},
  {0x24, 0xD, "Write UPID RAM Value To Cmd Table Var 2", P(kUpid), kAll},
  {0x24, 0xE, "Write UPID RAM value To UPID ROM value", P(kUpid), kAll},
  // §5.14 Master IDs 25h, 26h — IF (MC22 L3114-3316)
  {0x25, 0x0, "IF Cmd Table Var 1 Less Than", P(kIf), kAll},
  {0x25, 0x1, "IF Cmd Table Var 1 Greater Than", P(kIf), kAll},
  {0x25, 0x2, "IF Cmd Table Var 2 Less Than", P(kIf), kAll},
  {0x25, 0x3, "IF Cmd Table Var 2 Greater Than", P(kIf), kAll},
  {0x25, 0x6, "IF Cmd Table Var 1 Less Than UPID Value", P(kIf), kAll},  // D-18
  {0x25, 0x7, "IF Cmd Table Var 2 Less Than UPID Value", P(kIf), kAll},  // D-18
  {0x25, 0x8, "IF Demand Position Less Than", P(kIf), kAll},
  {0x25, 0x9, "IF Demand Position Greater Than", P(kIf), kAll},
  {0x25, 0xA, "IF Actual Position Less Than", P(kIf), kAll},
  {0x25, 0xB, "IF Actual Position Greater Than", P(kIf), kAll},
  {0x25, 0xC, "IF Difference Position Less Than", P(kIf), kAll},
  {0x25, 0xD, "IF Difference Position Greater Than", P(kIf), kAll},
  {0x25, 0xE, "IF Current Less Than", P(kIf), kAll},
  {0x25, 0xF, "IF Current Greater Than", P(kIf), kAll},
  {0x26, 0x0, "IF Analog Val On X4.4 Less Than", P(kIf), kAll},
  {0x26, 0x2, "IF Masked X4 Input Value Equal Than", P(kIfMasked), kAll},
  {0x26, 0x3, "IF Masked X6 Input Value Equal Than", P(kIfMasked), kE12E14},
  {0x26, 0x4, "IF Masked Status Word Equal Than", P(kIfMasked), kAll},
  {0x26, 0x5, "IF Masked Warn Word Equal Than", P(kIfMasked), kAll},
  {0x26, 0x6, "IF CAM Counts Less Than", P(kIf), kE12E14},
  // §5.15 Master IDs 30h, 31h — encoder winding (MC22 L3318-3362)
  {0x30, 0x0, "Encoder Winding Start With Default Parameters", kHeaderOnly, kE1200Only},
  {0x30, 0x1, "Encoder Winding Start With Default Parameters At Revolutions", P(kP301), kE1200Only},
  {0x30, 0x4, "Encoder Winding Stop Adaptation Of Left/Right Position and Disturbance", kHeaderOnly, kE1200Only},
  {0x30, 0x5, "Encoder Winding Restart Adaptation Of Left/Right Position and Disturbance", kHeaderOnly, kE1200Only},
  {0x31, 0x0, "Encoder Curve Winding Start With Default Parameters", P(kCurveId), kE1200Only},
  {0x31, 0x1, "Encoder Curve Winding Start With Default Parameters At Revolutions", P(kP311), kE1200Only},
  // §5.16 Master IDs 38h, 39h — force and current control (MC22 L3364-3576)
  {0x38, 0x0, "VAI Go To Pos With Higher Force Ctrl Limit", P(kP380), kForce4},
  {0x38, 0x1, "VAI Go To Pos From Act Pos And Reset Force Control", P(kVaTarget), kForce4},
  {0x38, 0x2, "Force Ctrl Change Target Force", P(kP382), kForce4},
  {0x38, 0x3, "VAI Go To Pos With Higher Force Ctrl Limit and Target Force", P(kP383), kForce4},
  {0x38, 0x4, "VAI Go To Pos With Lower Force Ctrl Limit", P(kP380), kForce4},
  {0x38, 0x5, "VAI Go To Pos With Lower Force Ctrl Limit and Target Force", P(kP383), kForce4},
  {0x38, 0x6, "VAI Go To Pos From Act Pos And Reset Force Control Set I", P(kVaTarget), kForce4},
  {0x38, 0x7, "VAI Increment Act Pos And Reset Force Control Set I", P(kVaIncrement), kForce4},
  {0x38, 0x8, "VAI Inc Act Pos With Higher Force Ctrl Limit and Target Force", P(kP388), kForce4},
  {0x38, 0x9, "VAI Inc Act Pos With Lower Force Ctrl Limit and Target Force", P(kP388), kForce4},
  {0x38, 0xA, "VAI Go To Pos Tara Diff Analog In -10V..10V", P(kP38A), kForceC1250},
  {0x38, 0xB, "Standstill Tara Diff Analog In -10V..10V", P(kP38B), kForceC1250},
  {0x39, 0x0, "Current Command Mode", P(kP390), kAll},
  {0x39, 0x8, "Closed Loop Force Command Mode Rel", P(kP398), kNotE1200},
  {0x39, 0x9, "Closed Loop Force Command Mode Abs", P(kP399), kNotE1200},
  {0x39, 0xF, "Change to Position Controlled Mode", kHeaderOnly, kNotC1100},
  // §5.17 Master IDs 3Ah, 3Bh — VAJI (MC22 L3578-3764)
  {0x3A, 0x0, "VAJI Go To Pos", P(kVajTarget), kC1250E1400},
  {0x3A, 0x1, "VAJI Increment Dem Pos", P(kVajIncrement), kC1250E1400},
  {0x3A, 0x2, "VAJI Increment Target Pos", P(kVajIncrement), kC1250E1400},
  {0x3A, 0x4, "VAJI Go To Pos From Act Pos Starting With Dem Vel = 0 and Dem Acc = 0", P(kVajTarget), kC1250E1400},
  {0x3A, 0x6, "VAJI Increment Act Pos Starting With Dem Vel = 0 and Dem Acc = 0", P(kVajIncrement), kC1250E1400},
  {0x3A, 0xA, "VAJI Go To Pos On Rising Trigger Event", P(kVajTarget), kC1250E1400},
  {0x3A, 0xB, "VAJI Increment Target Pos On Rising Trigger Event", P(kVajIncrement), kC1250E1400},
  {0x3A, 0xC, "VAJI Go To Pos On Falling Trigger Event", P(kVajTarget), kC1250E1400},
  {0x3A, 0xD, "VAJI Increment Target Pos On Falling Trigger Event", P(kVajIncrement), kC1250E1400},
  {0x3B, 0x0, "Predef VAJI Go To Pos", P(kPTarget), kC1250E1400},
  {0x3B, 0x1, "Predef VAJI Increment Dem Pos", P(kPIncrement), kC1250E1400},
  {0x3B, 0x2, "Predef VAJI Increment Target Pos", P(kPIncrement), kC1250E1400},
  {0x3B, 0x4, "Predef VAJI Go To Pos From Act Pos Starting With Dem Vel = 0 and Dem Acc = 0", P(kPTarget), kC1250E1400},
  {0x3B, 0xA, "Predef VAJI Go To Pos On Rising Trigger Event", P(kPTarget), kC1250E1400},
  {0x3B, 0xB, "Predef VAJI Increment Target Pos On Rising Trigger Event", P(kPIncrement), kC1250E1400},
  {0x3B, 0xC, "Predef VAJI Go To Pos On Falling Trigger Event", P(kPTarget), kC1250E1400},
  {0x3B, 0xD, "Predef VAJI Increment Target Pos On Falling Trigger Event", P(kPIncrement), kC1250E1400},
  // §5.18 Master ID 3Ch — modulo VAI (MC22 L3766-3796); 3C0 with deceleration per D-19
  {0x3C, 0x0, "VAI Modulo Go To Pos Positive Direction", P(kVaTarget), kC1250Only},
  {0x3C, 0x1, "VAI Modulo Go To Pos Negative Direction", P(kVaTarget), kC1250Only},
  {0x3C, 0x2, "VAI Modulo Go To Pos Shortest Way", P(kVaTarget), kC1250Only},
};
// clang-format on

constexpr bool Sorted() {
  for (size_t i = 1; i < std::size(kCommands); ++i) {
    const auto& a = kCommands[i - 1];
    const auto& b = kCommands[i];
    if (a.master_id > b.master_id || (a.master_id == b.master_id && a.sub_id >= b.sub_id)) {
      return false;
    }
  }
  return true;
}
static_assert(Sorted(), "kCommands must be strictly ordered by (master_id, sub_id)");

// Layout sanity: parameters back to back without gaps or overlap (§4.1), all inside 32 bytes.
constexpr bool Packed() {
  for (const auto& c : kCommands) {
    size_t next = 2;
    for (const auto& p : c.params) {
      if (p.offset != next) return false;
      next += ParamTypeSize(p.type);
    }
    if (next > kMcBlockSize) return false;
  }
  return true;
}
static_assert(Packed(), "every layout must be packed from offset 2 (linmot-mc.md §4.1)");

}  // namespace

std::span<const CommandSpec> AllCommands() { return kCommands; }

const CommandSpec* FindCommand(uint8_t master_id, uint8_t sub_id) {
  const auto* end = std::end(kCommands);
  const auto* it = std::lower_bound(std::begin(kCommands), end, std::pair{master_id, sub_id},
                                    [](const CommandSpec& c, std::pair<uint8_t, uint8_t> k) {
                                      return std::pair{c.master_id, c.sub_id} < k;
                                    });
  if (it == end || it->master_id != master_id || it->sub_id != sub_id) return nullptr;
  return it;
}

}  // namespace drivegw::linmot::mc
