// Pins gRPC 1.51's process-wide "callback alternative" completion queue for a test binary.
//
// Where gRPC's poller cannot run callbacks in the background (this sandbox's kernel makes it pick
// one that cannot), every channel that makes a callback-API call takes a reference on one shared
// CompletionQueue with its own nexting threads, and the last channel to go shuts it down. A test
// binary that creates and destroys many channels (routers, gateways) hits a race in that shutdown:
// grpc_cq_internal_unref aborts with "prior > 0" in a nexting thread (seen in test_rest in about
// one whole-binary run in four, and once under ctest). One channel made here, used once with the
// callback API and never destroyed, holds a reference for the life of the process, so the shared
// queue is never shut down while tests run or at exit. Production keeps its channels for the
// process lifetime anyway.
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <memory>

namespace {

class CallbackCqPin final : public ::testing::Environment {
 public:
  void SetUp() override {
    // Intentionally never destroyed (see above): a leaked channel, not a static one whose
    // destructor would release the queue during exit.
    static std::shared_ptr<grpc::Channel>* const pinned = new std::shared_ptr<grpc::Channel>(
        grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials()));
    grpc::GenericStub stub(*pinned);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    grpc::Slice empty("");
    grpc::ByteBuffer request(&empty, 1);  // a default ByteBuffer is "no message": API misuse
    grpc::ByteBuffer response;
    std::promise<void> done;
    stub.UnaryCall(&context, "/drivegw.test.Pin/Pin", grpc::StubOptions(), &request, &response,
                   [&](const grpc::Status&) { done.set_value(); });
    done.get_future().wait();  // fails (no server): only the reference on the queue matters
  }
};

// gtest_main runs the environment before the first test.
[[maybe_unused]] ::testing::Environment* const kPin =
    ::testing::AddGlobalTestEnvironment(std::make_unique<CallbackCqPin>().release());

}  // namespace
