// The WebSocket target's query becomes the router's WatchDrives request (decision 504 item 2):
// default rate, comma lists, the token as a Bearer authorization, unknown keys refused.
#include <gtest/gtest.h>

#include "server/rest/ws_session.h"

namespace drivegw::rest {
namespace {

TEST(WsQuery, Defaults_Rate10EveryDriveNoToken) {
  auto r = WatchRequestFor("/v1/drives:ws");
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->method, "GET");
  EXPECT_EQ(r->target, "/v1/drives:watch?max_rate_hz=10");
  EXPECT_EQ(r->authorization, "");
}

TEST(WsQuery, NamesRateToken_RepeatedNamesAndBearer) {
  auto r = WatchRequestFor(
      "/v1/drives:ws?max_rate_hz=2.5&names=x1,feeder-x&names=d1%2Cs1"
      "&access_token=dgw_ab_c%2Bd");
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->target,
            "/v1/drives:watch?max_rate_hz=2.5&names=x1&names=feeder-x&names=d1&names=s1");
  EXPECT_EQ(r->authorization, "Bearer dgw_ab_c+d");
}

TEST(WsQuery, UnknownKeyOrBadEscape_InvalidArgument) {
  auto r = WatchRequestFor("/v1/drives:ws?name=x1");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("name"), absl::string_view::npos) << r.status();
  EXPECT_EQ(WatchRequestFor("/v1/drives:ws?names=%zz").status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace drivegw::rest
