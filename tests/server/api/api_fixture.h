// The API test fixture: the real stack (REST router -> in-process gRPC -> DriveServiceGrpc ->
// DriveServiceCore) over FakeDrives (tests/server/core/fake_drive.h), plus a gRPC stub over TCP.
// Drives: feeder-x, feeder-y (trinamic, interpolating), lin1, lin2 (linmot), st1 (stober).
#pragma once

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/worker_pool.h"
#include "server/rest/router.h"
#include "tests/server/core/core_test_support.h"
#include "tests/server/rest/recording_sink.h"

namespace drivegw::server::test_support {

class ApiRoundTripTest : public ::testing::Test {
 protected:
  ApiRoundTripTest()
      : x_(fleet_.Add("feeder-x", "trinamic", true)),
        y_(fleet_.Add("feeder-y", "trinamic", true)),
        lin1_(fleet_.Add("lin1", "linmot", false)),
        lin2_(fleet_.Add("lin2", "linmot", false)),
        st1_(fleet_.Add("st1", "stober", false)),
        core_(fleet_.drives(), nullptr),
        pool_(2),
        service_(core_, pool_, CallAuth::Open()) {}

  void SetUp() override {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&service_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    rest::RouterOptions o;
    o.channel = server_->InProcessChannel(grpc::ChannelArguments());
    o.openapi_json = "{}";
    auto router = rest::Router::Create(std::move(o));
    ASSERT_TRUE(router.ok()) << router.status();
    router_ = *std::move(router);
  }

  void TearDown() override {
    router_.reset();
    if (server_) {
      server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
      server_->Wait();
    }
    pool_.Shutdown();
  }

  rest::HttpResponse Post(std::string target, std::string body) {
    auto sink = std::make_shared<rest::test_support::RecordingSink>();
    router_->Handle({"POST", std::move(target), std::move(body), "10.0.0.7:5555"}, sink);
    return sink->Response();
  }

  static nlohmann::json Json(const rest::HttpResponse& r) {
    auto j = nlohmann::json::parse(r.body, nullptr, /*allow_exceptions=*/false);
    EXPECT_FALSE(j.is_discarded()) << r.body;
    return j;
  }

  std::unique_ptr<v1::DriveService::Stub> GrpcStub() {
    return v1::DriveService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                                         grpc::InsecureChannelCredentials()));
  }

  FakeFleet fleet_;
  FakeDrive& x_;
  FakeDrive& y_;
  FakeDrive& lin1_;
  FakeDrive& lin2_;
  FakeDrive& st1_;  // stober; tests switch its cyclic channel on
  DriveServiceCore core_;
  WorkerPool pool_;
  DriveServiceGrpc service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<rest::Router> router_;
};

}  // namespace drivegw::server::test_support
