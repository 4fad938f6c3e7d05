// Tests of the LinMot error code table and texts (linmot-mc.md §10, D-33).
#include "adapters/linmot/mc/error_codes.h"

#include <gtest/gtest.h>

#include <set>

namespace drivegw::linmot::mc {
namespace {

TEST(FindErrorCode, NamedConstants_AreInTableWithManualNames) {
  EXPECT_STREQ(FindErrorCode(kMotionCommandInWrongState)->text, "Motion Cmd In Wrong State");
  EXPECT_STREQ(FindErrorCode(kUnknownMotionCommand)->text, "Unknown Motion Cmd");
  EXPECT_STREQ(FindErrorCode(kPosLagAlwaysTooBig)->text, "Pos Lag Always Too Big");
  EXPECT_STREQ(FindErrorCode(kPosLagStandingTooBig)->text, "Pos Lag Standing Too Big");
  EXPECT_STREQ(FindErrorCode(kMinPosUndershot)->text, "Min Pos Undershot");
  EXPECT_STREQ(FindErrorCode(kMaxPosOvershot)->text, "Max Pos Overshot");
  EXPECT_STREQ(FindErrorCode(kCurveNotDefined)->text, "Curve Not Defined");
  EXPECT_STREQ(FindErrorCode(kParRangeError)->text, "Par Range Error");
  EXPECT_EQ(kMotionCommandInWrongState, 0x0086);
  EXPECT_EQ(kUnknownMotionCommand, 0x0081);
}

TEST(FindErrorCode, UnrecoverableCodes_Null) {
  // §10: codes not recoverable from either source.
  for (uint16_t c : {0x001F, 0x0026, 0x002D, 0x003D, 0x0043, 0x0048, 0x0052, 0x005F, 0x0066, 0x006A,
                     0x006C, 0x007F, 0x008B, 0x008F, 0x0094, 0xFFFF}) {
    EXPECT_EQ(FindErrorCode(c), nullptr) << c;
  }
}

TEST(AllErrorCodes, Table_AscendingUniqueAndComplete) {
  std::set<uint16_t> seen;
  for (const ErrorCode& e : AllErrorCodes()) {
    EXPECT_TRUE(seen.insert(e.code).second) << e.code;
    EXPECT_EQ(FindErrorCode(e.code), &e);
  }
  // §10 lists 91 codes once ranges (0030h/0031h, ..., 0090h-0093h) are expanded.
  EXPECT_EQ(seen.size(), 91u);
  EXPECT_EQ(*seen.begin(), 0x0000);
  EXPECT_EQ(*seen.rbegin(), 0x0093);
}

TEST(IsFatal, FatalRows_True) {
  for (uint16_t c : {0x000A, 0x000D, 0x0021, 0x0022, 0x0045, 0x0064, 0x0065, 0x0067, 0x0068}) {
    EXPECT_TRUE(IsFatal(c)) << c;
  }
  EXPECT_FALSE(IsFatal(kMotionCommandInWrongState));
  EXPECT_FALSE(IsFatal(0x1234));  // unknown: the status word decides
  EXPECT_EQ(FindErrorCode(kPwrOverCurrent)->error_class, ErrorClass::kFatalErr);
  EXPECT_STREQ(ErrorClassName(FindErrorCode(0x0081)->error_class), "User Err");
}

TEST(ErrorText, KnownCode_NameAndHex) {
  EXPECT_EQ(ErrorText(0x0086), "Motion Cmd In Wrong State (0x0086)");
  EXPECT_EQ(ErrorText(0x000B), "Pos Lag Always Too Big (0x000B)");
}

TEST(ErrorText, UnknownCode_GenericD33) {
  EXPECT_EQ(ErrorText(0x0099), "LinMot error 0x0099");
  EXPECT_EQ(ErrorText(0xABCD), "LinMot error 0xABCD");
}

TEST(AttachErrorCode, NonOkStatus_RoundTrips) {
  absl::Status s = absl::FailedPreconditionError("x1: drive in error state");
  AttachErrorCode(s, 0x0086);
  EXPECT_EQ(GetErrorCode(s), 0x0086);
  EXPECT_EQ(GetErrorCode(absl::InternalError("no payload")), std::nullopt);
}

TEST(AttachErrorCode, OkStatus_NoPayload) {
  absl::Status s = absl::OkStatus();
  AttachErrorCode(s, 0x0086);
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(GetErrorCode(s), std::nullopt);
}

}  // namespace
}  // namespace drivegw::linmot::mc
