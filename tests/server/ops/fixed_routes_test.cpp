// The REST router's fixed GET routes (decision 021): /readyz answers 503 with the reason until
// storage is open and every drive was tried, then 200; other methods get 405.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "server/ops/readiness.h"
#include "server/rest/router.h"
#include "tests/server/rest/recording_sink.h"

namespace drivegw::rest {
namespace {

HttpResponse Call(Router& router, const std::string& method, const std::string& target) {
  auto sink = std::make_shared<test_support::RecordingSink>();
  HttpRequest req;
  req.method = method;
  req.target = target;
  router.Handle(std::move(req), sink);
  return sink->Response();
}

TEST(FixedRoutes_Readyz, NotReady503ThenReady200) {
  ops::Readiness readiness;
  RouterOptions o;
  // Fixed routes never touch the channel (a channel to nothing proves it).
  o.channel = grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials());
  o.fixed_routes["/readyz"] = [&] {
    const absl::Status s = readiness.Check();
    HttpResponse r;
    r.status = s.ok() ? 200 : 503;
    r.content_type = "text/plain";
    r.body = s.ok() ? "ready\n" : absl::StrCat("not ready: ", s.message(), "\n");
    return r;
  };
  auto router = Router::Create(std::move(o));
  ASSERT_TRUE(router.ok()) << router.status();

  readiness.SetStorageOpen(true);
  readiness.ExpectDrives({"x1"});
  HttpResponse r = Call(**router, "GET", "/readyz");
  EXPECT_EQ(r.status, 503);
  EXPECT_EQ(r.body, "not ready: drives not tried yet: x1\n");

  readiness.MarkDriveTried("x1");
  r = Call(**router, "GET", "/readyz?verbose=1");  // the query is not part of the path
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "ready\n");

  r = Call(**router, "POST", "/readyz");
  EXPECT_EQ(r.status, 405);
  ASSERT_FALSE(r.headers.empty());
  EXPECT_EQ(r.headers[0].second, "GET");
}

}  // namespace
}  // namespace drivegw::rest
