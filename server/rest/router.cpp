// REST router: routes from google.api.http rules, request building by reflection, and unary /
// server-streaming in-process calls with grpc::GenericStub; errors as google.rpc.Status JSON.
#include "server/rest/router.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "drivegw/v1/drive.pb.h"
#include "drivegw/v1/parameter_sets.pb.h"
#include "google/api/annotations.pb.h"
#include "google/protobuf/arena.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"
#include "google/protobuf/util/json_util.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "server/rest/json_cache.h"
#include "server/rest/json_print.h"
#include "server/rest/static_assets.h"

namespace drivegw::rest {
namespace pb = google::protobuf;

namespace {

// abseil 20220623 is built without std::string_view (ABSL_OPTION_USE_STD_STRING_VIEW 0).
absl::string_view Av(std::string_view s) { return absl::string_view(s.data(), s.size()); }
std::string_view Sv(absl::string_view s) { return std::string_view(s.data(), s.size()); }

constexpr int kInvalidArgument = 3;
constexpr int kNotFound = 5;
constexpr int kUnimplemented = 12;
constexpr int kInternal = 13;
constexpr int kUnavailable = 14;
constexpr size_t kMaxStaticFile = 32u << 20;
// First arena block of a request message and a direct route's response, on the stack: x1's
// Drive needs ≈ 2 KB (a list of many drives, or a large JSON body, continues in heap blocks).
constexpr size_t kDirectArenaBlock = 4096;

pb::util::JsonPrintOptions PrintOptions() {
  pb::util::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  return o;
}

HttpResponse JsonResponse(int status, std::string body) {
  HttpResponse r;
  r.status = status;
  r.body = std::move(body);
  return r;
}

HttpResponse TextResponse(int status, std::string body) {
  HttpResponse r;
  r.status = status;
  r.content_type = "text/plain; charset=utf-8";
  r.body = std::move(body);
  return r;
}

// The body of an error response: the google.rpc.Status the server attached (with its Any
// details, e.g. google.rpc.BadRequest), else {code, message}.
HttpResponse ErrorBodyFromGrpc(const grpc::Status& status) {
  const int code = static_cast<int>(status.error_code());
  const int http = HttpStatusForGrpcCode(code);
  if (!status.error_details().empty()) {
    google::rpc::Status rich;
    std::string json;
    if (rich.ParseFromString(status.error_details()) &&
        pb::util::MessageToJsonString(rich, &json, PrintOptions()).ok()) {
      // A stale etag is 412 Precondition Failed (RFC 9110 §15.5.13; decision 011), not 400.
      for (const auto& any : rich.details()) {
        google::rpc::PreconditionFailure pf;
        if (any.Is<google::rpc::PreconditionFailure>() && any.UnpackTo(&pf)) {
          for (const auto& v : pf.violations()) {
            if (v.type() == "ETAG") return JsonResponse(412, std::move(json));
          }
        }
      }
      return JsonResponse(http, std::move(json));
    }
  }
  return ErrorResponse(http, code, status.error_message());
}

// ErrorBodyFromGrpc; a 401 also names the scheme to use (RFC 7235 §3.1, RFC 6750 §3; decision
// 015).
HttpResponse ErrorFromGrpc(const grpc::Status& status) {
  HttpResponse r = ErrorBodyFromGrpc(status);
  if (r.status == 401) r.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"drivegw\"");
  return r;
}

// Field lookup by proto name ("max_rate_hz") or JSON name ("maxRateHz").
const pb::FieldDescriptor* FindField(const pb::Descriptor* d, absl::string_view name) {
  if (const auto* f = d->FindFieldByName(std::string(name))) return f;
  for (int i = 0; i < d->field_count(); ++i) {
    if (d->field(i)->json_name() == name) return d->field(i);
  }
  return nullptr;
}

// Walks "a.b.c" down from `d`; every component but the last must be a singular message.
absl::StatusOr<std::vector<const pb::FieldDescriptor*>> ResolvePath(const pb::Descriptor* d,
                                                                    absl::string_view path) {
  std::vector<const pb::FieldDescriptor*> fields;
  for (absl::string_view part : absl::StrSplit(path, '.')) {
    if (d == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat(fields.back()->name(), " is not a message"));
    }
    const auto* f = FindField(d, part);
    if (f == nullptr) {
      return absl::NotFoundError(absl::StrCat("no field ", part, " in ", d->full_name()));
    }
    if (!fields.empty() && fields.back()->is_repeated()) {
      return absl::InvalidArgumentError(absl::StrCat(fields.back()->name(), " is repeated"));
    }
    fields.push_back(f);
    d = f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE ? f->message_type() : nullptr;
  }
  return fields;
}

// Sets (or, for repeated fields, adds) a scalar field from its text form. The error says what
// the value is not ("\"abc\" is not a valid uint32").
absl::Status SetScalar(pb::Message* msg, const pb::FieldDescriptor* f, absl::string_view value) {
  const pb::Reflection* r = msg->GetReflection();
  const bool rep = f->is_repeated();
  auto bad = [&](absl::string_view type) {
    return absl::InvalidArgumentError(
        absl::StrCat("\"", absl::CHexEscape(value), "\" is not a valid ", type));
  };
  switch (f->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_STRING: {
      std::string v(value);
      if (f->type() == pb::FieldDescriptor::TYPE_BYTES && !absl::Base64Unescape(value, &v) &&
          !absl::WebSafeBase64Unescape(value, &v)) {
        return bad("base64 bytes value");
      }
      rep ? r->AddString(msg, f, std::move(v)) : r->SetString(msg, f, std::move(v));
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_INT32: {
      int32_t v;
      if (!absl::SimpleAtoi(value, &v)) return bad("int32");
      rep ? r->AddInt32(msg, f, v) : r->SetInt32(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_INT64: {
      int64_t v;
      if (!absl::SimpleAtoi(value, &v)) return bad("int64");
      rep ? r->AddInt64(msg, f, v) : r->SetInt64(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_UINT32: {
      uint32_t v;
      if (value.find('-') != absl::string_view::npos || !absl::SimpleAtoi(value, &v)) {
        return bad("uint32");
      }
      rep ? r->AddUInt32(msg, f, v) : r->SetUInt32(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_UINT64: {
      uint64_t v;
      if (value.find('-') != absl::string_view::npos || !absl::SimpleAtoi(value, &v)) {
        return bad("uint64");
      }
      rep ? r->AddUInt64(msg, f, v) : r->SetUInt64(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_DOUBLE: {
      double v;
      if (!absl::SimpleAtod(value, &v)) return bad("double");
      rep ? r->AddDouble(msg, f, v) : r->SetDouble(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_FLOAT: {
      float v;
      if (!absl::SimpleAtof(value, &v)) return bad("float");
      rep ? r->AddFloat(msg, f, v) : r->SetFloat(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_BOOL: {
      bool v;
      if (value == "true" || value == "1") {
        v = true;
      } else if (value == "false" || value == "0") {
        v = false;
      } else {
        return bad("bool (true, false, 1, 0)");
      }
      rep ? r->AddBool(msg, f, v) : r->SetBool(msg, f, v);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_ENUM: {
      int number;
      if (const auto* ev = f->enum_type()->FindValueByName(std::string(value))) {
        number = ev->number();
      } else if (!absl::SimpleAtoi(value, &number) ||
                 f->enum_type()->FindValueByNumber(number) == nullptr) {
        return bad(f->enum_type()->full_name());
      }
      rep ? r->AddEnumValue(msg, f, number) : r->SetEnumValue(msg, f, number);
      return absl::OkStatus();
    }
    case pb::FieldDescriptor::CPPTYPE_MESSAGE:
      break;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("is a message (", f->message_type()->full_name(), "); set it in the JSON body"));
}

// Sets the field at `fields` (from ResolvePath) below `msg`, creating the parents.
absl::Status SetPath(pb::Message* msg, const std::vector<const pb::FieldDescriptor*>& fields,
                     absl::string_view text) {
  for (size_t i = 0; i + 1 < fields.size(); ++i) {
    msg = msg->GetReflection()->MutableMessage(msg, fields[i]);
  }
  return SetScalar(msg, fields.back(), text);
}

std::string FieldPathName(const std::vector<const pb::FieldDescriptor*>& fields) {
  return absl::StrJoin(
      fields, ".", [](std::string* out, const pb::FieldDescriptor* f) { out->append(f->name()); });
}

// A protobuf JSON parse error split into the field it names (if any) and what went wrong.
// protobuf 3.21 says "(a.b): invalid value \"x\" for type TYPE_DOUBLE" or "speed: Cannot find
// field." (and ": Root element must be a message." without a field).
struct JsonError {
  std::string field;
  std::string what;
};
JsonError SplitJsonError(absl::string_view message) {
  if (absl::StartsWith(message, "(")) {
    const size_t close = message.find("): ");
    if (close != absl::string_view::npos && close > 1) {
      return {std::string(message.substr(1, close - 1)), std::string(message.substr(close + 3))};
    }
  }
  constexpr absl::string_view kUnknown = ": Cannot find field";
  if (const size_t at = message.find(kUnknown);
      at != absl::string_view::npos && at > 0 &&
      message.substr(0, at).find(' ') == absl::string_view::npos) {
    return {std::string(message.substr(0, at)), "no such field"};
  }
  absl::ConsumePrefix(&message, ": ");
  return {{}, std::string(message)};
}

grpc::ByteBuffer ToByteBuffer(const std::string& bytes) {
  // toolchain.md pitfall 3: even an empty request needs a real slice.
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

std::optional<std::string> BufferBytes(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  if (!buffer.Dump(&slices).ok()) return std::nullopt;
  std::string bytes;
  for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return bytes;
}

bool FromByteBuffer(const grpc::ByteBuffer& buffer, pb::Message* msg) {
  const auto bytes = BufferBytes(buffer);
  return bytes && msg->ParseFromString(*bytes);
}

// Response message -> JSON, or the part named by the rule's response_body; through `cache` when
// given (decision 1361).
absl::StatusOr<std::string> ResponseJson(const pb::Message& msg, const std::string& response_body,
                                         JsonCache* cache) {
  const pb::Message* out = &msg;
  if (!response_body.empty()) {
    const auto* f = msg.GetDescriptor()->FindFieldByName(response_body);
    out = &msg.GetReflection()->GetMessage(msg, f);
  }
  // PrintJson: MessageToJsonString's bytes, mostly without its cost (decision 1332).
  auto json = cache != nullptr ? cache->Print(*out) : PrintJson(*out);
  if (!json.ok()) {
    return absl::InternalError(absl::StrCat("response to JSON: ", json.status().message()));
  }
  return json;
}

// What a finished unary call answers, for the gRPC and the direct path alike: the mapped
// error, or `out` (or its response_body part) as JSON.
HttpResponse UnaryResponse(const grpc::Status& status, const pb::Message& out,
                           const std::string& response_body, JsonCache* cache = nullptr) {
  if (!status.ok()) return ErrorFromGrpc(status);
  auto json = ResponseJson(out, response_body, cache);
  if (!json.ok()) return ErrorResponse(500, kInternal, std::string(json.status().message()));
  return JsonResponse(200, *std::move(json));
}

std::unique_ptr<pb::Message> NewMessage(const pb::Descriptor* type) {
  return std::unique_ptr<pb::Message>(
      pb::MessageFactory::generated_factory()->GetPrototype(type)->New());
}

}  // namespace

// --- error helpers --------------------------------------------------------------------------

namespace {

// The length of the well-formed UTF-8 sequence at the start of `s` (RFC 3629 §4: no overlong
// forms, no surrogates, nothing above U+10FFFF), 0 when there is none.
size_t Utf8SequenceLength(std::string_view s) {
  const auto b = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const auto tail = [&](size_t i, unsigned lo = 0x80, unsigned hi = 0xBF) {
    return i < s.size() && b(i) >= lo && b(i) <= hi;
  };
  const unsigned c = b(0);
  if (c < 0x80) return 1;
  if (c >= 0xC2 && c <= 0xDF) return tail(1) ? 2 : 0;
  if (c >= 0xE0 && c <= 0xEF) {
    const bool second = c == 0xE0 ? tail(1, 0xA0) : c == 0xED ? tail(1, 0x80, 0x9F) : tail(1);
    return second && tail(2) ? 3 : 0;
  }
  if (c >= 0xF0 && c <= 0xF4) {
    const bool second = c == 0xF0 ? tail(1, 0x90) : c == 0xF4 ? tail(1, 0x80, 0x8F) : tail(1);
    return second && tail(2) && tail(3) ? 4 : 0;
  }
  return 0;
}

}  // namespace

std::string ValidUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  while (!text.empty()) {
    const size_t n = Utf8SequenceLength(text);
    if (n == 0) {
      absl::StrAppend(&out, "\\x", absl::Hex(static_cast<unsigned char>(text[0]), absl::kZeroPad2));
      text.remove_prefix(1);
    } else {
      out.append(text.substr(0, n));
      text.remove_prefix(n);
    }
  }
  return out;
}

HttpResponse ErrorResponse(int http_status, int grpc_code, std::string message, std::string field,
                           std::string field_description) {
  // Messages quote what the client sent (a query parameter, a field name); protobuf strings and
  // JSON must be UTF-8, so a byte that is not is shown as \xNN (found by rest_body_fuzz:
  // MessageToJsonString failed and the fallback's C escapes were not JSON, decision 1403).
  message = ValidUtf8(message);
  field = ValidUtf8(field);
  field_description = ValidUtf8(field_description);
  google::rpc::Status status;
  status.set_code(grpc_code);
  status.set_message(message);
  if (!field.empty()) {
    google::rpc::BadRequest bad;
    auto* v = bad.add_field_violations();
    v->set_field(std::move(field));
    v->set_description(field_description.empty() ? message : std::move(field_description));
    status.add_details()->PackFrom(bad);
  }
  std::string json;
  if (!pb::util::MessageToJsonString(status, &json, PrintOptions()).ok()) {
    // Not reached with UTF-8 text; kept JSON-valid anyway: the message as a JSON string.
    json = absl::StrCat("{\"code\":", grpc_code, ",\"message\":", nlohmann::json(message).dump(),
                        ",\"details\":[]}");
  }
  return JsonResponse(http_status, std::move(json));
}

int HttpStatusForGrpcCode(int grpc_code) {
  switch (static_cast<grpc::StatusCode>(grpc_code)) {
    case grpc::StatusCode::OK:
      return 200;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE:
    case grpc::StatusCode::FAILED_PRECONDITION:
      return 400;
    case grpc::StatusCode::NOT_FOUND:
      return 404;
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::ABORTED:
      return 409;
    case grpc::StatusCode::PERMISSION_DENIED:
      return 403;
    case grpc::StatusCode::UNAUTHENTICATED:
      return 401;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return 429;
    case grpc::StatusCode::UNIMPLEMENTED:
      return 501;
    case grpc::StatusCode::UNAVAILABLE:
      return 503;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return 504;
    default:
      return 500;
  }
}

// --- calls in flight ------------------------------------------------------------------------

namespace {
class Call {
 public:
  virtual ~Call() = default;
  virtual void Cancel() noexcept = 0;
};
}  // namespace

struct Router::Inflight {
  std::mutex mu;
  std::condition_variable idle;
  std::map<const Call*, std::shared_ptr<Call>> calls;
  bool stopping = false;

  bool Add(std::shared_ptr<Call> call) {
    std::lock_guard lock(mu);
    if (stopping) return false;
    calls.emplace(call.get(), std::move(call));
    return true;
  }
  void Remove(const Call* call) {
    std::shared_ptr<Call> last;  // released outside the lock
    std::lock_guard lock(mu);
    if (auto it = calls.find(call); it != calls.end()) {
      last = std::move(it->second);
      calls.erase(it);
    }
    if (calls.empty()) idle.notify_all();
  }
};

namespace {

std::unique_ptr<grpc::ClientContext> MakeContext(const HttpRequest& request) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->AddMetadata("x-drivegw-source", request.peer.empty() ? "unknown" : request.peer);
  ctx->AddMetadata("x-drivegw-transport", "rest");
  if (!request.authorization.empty()) ctx->AddMetadata("authorization", request.authorization);
  if (!request.idempotency_key.empty()) {
    ctx->AddMetadata("idempotency-key", request.idempotency_key);
  }
  if (!request.client_cn.empty()) ctx->AddMetadata("x-drivegw-client-cn-bin", request.client_cn);
  if (!request.lease_id.empty()) ctx->AddMetadata("x-drivegw-lease", request.lease_id);
  return ctx;
}

// One unary call: lives in the in-flight table until its completion ran.
class UnaryCall final : public Call {
 public:
  using Finish = std::function<HttpResponse(const grpc::Status&, const grpc::ByteBuffer&)>;
  UnaryCall(std::unique_ptr<grpc::ClientContext> ctx, grpc::ByteBuffer request,
            std::shared_ptr<ResponseSink> sink, Finish finish)
      : ctx_(std::move(ctx)),
        request_(std::move(request)),
        sink_(std::move(sink)),
        finish_(std::move(finish)) {}

  static void Start(std::shared_ptr<UnaryCall> call, grpc::GenericStub& stub,
                    const std::string& method, const std::shared_ptr<Router::Inflight>& inflight) {
    if (!inflight->Add(call)) {
      call->sink_->OnResponse(ErrorResponse(503, kUnavailable, "REST server is stopping"));
      return;
    }
    UnaryCall* raw = call.get();
    stub.UnaryCall(raw->ctx_.get(), method, grpc::StubOptions(), &raw->request_, &raw->response_,
                   [call = std::move(call), inflight](grpc::Status status) noexcept {
                     call->Complete(status);
                     inflight->Remove(call.get());
                   });
  }

  void Cancel() noexcept override { ctx_->TryCancel(); }

 private:
  void Complete(const grpc::Status& status) noexcept {
    std::shared_ptr<ResponseSink> sink = std::move(sink_);
    HttpResponse response;
    try {
      response = finish_(status, response_);
    } catch (const std::exception& e) {
      response = ErrorResponse(500, kInternal, absl::StrCat("REST transcoding: ", e.what()));
    }
    sink->OnResponse(std::move(response));
  }

  std::unique_ptr<grpc::ClientContext> ctx_;
  grpc::ByteBuffer request_;
  grpc::ByteBuffer response_;
  std::shared_ptr<ResponseSink> sink_;
  Finish finish_;
};

// One server-streaming call, made as a generic bidi call that writes its single request and
// half-closes. A hold keeps OnDone away until the stream ended or was cancelled, so
// RequestNext never races the reactor's end (grpc callback API: AddHold/RemoveHold).
class StreamReactor final : public grpc::ClientBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>,
                            public StreamCall,
                            public Call,
                            public std::enable_shared_from_this<StreamReactor> {
 public:
  StreamReactor(std::unique_ptr<grpc::ClientContext> ctx, grpc::ByteBuffer request,
                std::shared_ptr<ResponseSink> sink, const pb::Descriptor* output,
                std::shared_ptr<Router::Inflight> inflight)
      : ctx_(std::move(ctx)),
        request_(std::move(request)),
        sink_(std::move(sink)),
        output_(output),
        inflight_(std::move(inflight)) {}

  void Start(grpc::GenericStub& stub, const std::string& method) {
    if (!inflight_->Add(shared_from_this())) {
      sink_->OnResponse(ErrorResponse(503, kUnavailable, "REST server is stopping"));
      return;
    }
    self_ = shared_from_this();
    stub.PrepareBidiStreamingCall(ctx_.get(), method, grpc::StubOptions(), this);
    AddHold();
    StartWriteLast(&request_, grpc::WriteOptions());
    StartCall();
    sink_->OnStreamStarted(shared_from_this());
    bool release;
    {
      std::lock_guard lock(mu_);
      started_ = true;
      release = release_requested_;
    }
    if (release) ReleaseHold();  // CancelAll came before the hold existed
  }

  void RequestNext() noexcept override {
    std::lock_guard lock(mu_);
    if (hold_released_) return;
    StartRead(&response_);
  }

  void Cancel() noexcept override {
    ctx_->TryCancel();
    ReleaseHold();
  }

 private:
  void ReleaseHold() noexcept {
    std::lock_guard lock(mu_);  // recursive: RemoveHold may run OnDone inline
    if (!started_) {
      release_requested_ = true;
      return;
    }
    if (hold_released_) return;
    hold_released_ = true;
    RemoveHold();
  }

  void OnReadDone(bool ok) noexcept override {
    if (!ok) {  // the stream ended (status follows in OnDone) or was cancelled
      ReleaseHold();
      return;
    }
    std::unique_ptr<pb::Message> msg(
        pb::MessageFactory::generated_factory()->GetPrototype(output_)->New());
    absl::StatusOr<std::string> printed;
    if (!FromByteBuffer(response_, msg.get()) || !(printed = PrintJson(*msg)).ok()) {
      log::Error("rest.stream_decode", log::Fields().Add("type", output_->full_name()));
      ctx_->TryCancel();
      ReleaseHold();
      return;
    }
    std::string json = *std::move(printed);
    json += '\n';
    sink_->OnStreamMessage(std::move(json));
  }

  void OnDone(const grpc::Status& status) noexcept override {
    std::shared_ptr<StreamReactor> self = std::move(self_);  // keeps `this` to the end
    std::shared_ptr<ResponseSink> sink = std::move(sink_);
    sink->OnStreamEnd(status.ok() ? HttpResponse{} : ErrorFromGrpc(status));
    sink.reset();
    inflight_->Remove(this);
  }

  std::unique_ptr<grpc::ClientContext> ctx_;
  grpc::ByteBuffer request_;
  grpc::ByteBuffer response_;
  std::shared_ptr<ResponseSink> sink_;
  const pb::Descriptor* output_;
  std::shared_ptr<Router::Inflight> inflight_;
  std::shared_ptr<StreamReactor> self_;  // from Start until OnDone
  std::recursive_mutex mu_;              // orders StartRead against the hold's release
  bool started_ = false;                 // the hold exists (Start is past AddHold)
  bool release_requested_ = false;       // Cancel before that
  bool hold_released_ = false;
};

absl::Status AddRoutes(const pb::MethodDescriptor* m, const google::api::HttpRule& rule,
                       bool top_level, std::vector<Route>& out) {
  const std::string where = absl::StrCat(m->full_name(), " google.api.http");
  if (!top_level && rule.additional_bindings_size() > 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": nested additional_bindings"));
  }
  Route route;
  std::string path;
  switch (rule.pattern_case()) {
    case google::api::HttpRule::kGet:
      route.http_method = "GET";
      path = rule.get();
      break;
    case google::api::HttpRule::kPut:
      route.http_method = "PUT";
      path = rule.put();
      break;
    case google::api::HttpRule::kPost:
      route.http_method = "POST";
      path = rule.post();
      break;
    case google::api::HttpRule::kDelete:
      route.http_method = "DELETE";
      path = rule.delete_();
      break;
    case google::api::HttpRule::kPatch:
      route.http_method = "PATCH";
      path = rule.patch();
      break;
    case google::api::HttpRule::kCustom:
      route.http_method = rule.custom().kind();
      path = rule.custom().path();
      break;
    case google::api::HttpRule::PATTERN_NOT_SET:
      return absl::InvalidArgumentError(absl::StrCat(where, ": no pattern"));
  }
  auto tmpl = PathTemplate::Parse(path);
  if (!tmpl.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": ", tmpl.status().message()));
  }
  route.path = *std::move(tmpl);
  for (const auto& var : route.path.variables()) {
    auto fields = ResolvePath(m->input_type(), var.field_path);
    if (!fields.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": path variable ", var.field_path, ": ", fields.status().message()));
    }
    const auto* leaf = fields->back();
    if (leaf->is_repeated() || leaf->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": path variable ", var.field_path, " must be a singular scalar"));
    }
    route.variable_names.push_back(FieldPathName(*fields));
    route.variable_fields.push_back(*std::move(fields));
  }
  route.body = rule.body();
  if (!route.body.empty() && route.body != "*" &&
      m->input_type()->FindFieldByName(route.body) == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": body ", route.body, " is no field of ",
                                                   m->input_type()->full_name()));
  }
  route.response_body = rule.response_body();
  if (!route.response_body.empty()) {
    const auto* f = m->output_type()->FindFieldByName(route.response_body);
    if (f == nullptr || f->is_repeated() || f->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": response_body ", route.response_body,
                                                     " must name a singular message field"));
    }
  }
  route.specificity = route.path.Specificity();
  {
    const auto& segs = route.path.segments();
    const bool multi_last = !segs.empty() && segs.back().kind == PathTemplate::SegmentKind::kMulti;
    route.min_segments = multi_last ? segs.size() - 1 : segs.size();
    route.max_segments = multi_last ? std::numeric_limits<size_t>::max() : segs.size();
  }
  route.method = m;
  route.request_prototype = pb::MessageFactory::generated_factory()->GetPrototype(m->input_type());
  route.grpc_path = absl::StrCat("/", m->service()->full_name(), "/", m->name());
  route.server_streaming = m->server_streaming();
  out.push_back(std::move(route));
  for (const auto& extra : rule.additional_bindings()) {
    DGW_RETURN_IF_ERROR(AddRoutes(m, extra, false, out));
  }
  return absl::OkStatus();
}

}  // namespace

// --- Router ---------------------------------------------------------------------------------

absl::StatusOr<std::unique_ptr<Router>> Router::Create(RouterOptions options) {
  if (options.channel == nullptr) return absl::InvalidArgumentError("rest router: no gRPC channel");
  // Touch the generated types so their descriptors are linked in and registered: the service
  // itself, and the error details that google.protobuf.Any may carry in a google.rpc.Status.
  (void)drivegw::v1::Drive::descriptor();
  (void)google::rpc::Status::descriptor();
  (void)google::rpc::BadRequest::descriptor();
  (void)google::rpc::ErrorInfo::descriptor();
  (void)google::rpc::PreconditionFailure::descriptor();
  (void)drivegw::v1::ParameterSet::descriptor();
  std::vector<Route> routes;
  std::vector<std::string> names{options.service};
  names.insert(names.end(), options.more_services.begin(), options.more_services.end());
  for (const std::string& name : names) {
    const auto* service = pb::DescriptorPool::generated_pool()->FindServiceByName(name);
    if (service == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("rest router: service ", name, " not in the descriptor pool"));
    }
    for (int i = 0; i < service->method_count(); ++i) {
      const auto* m = service->method(i);
      if (!m->options().HasExtension(google::api::http)) continue;
      if (m->client_streaming()) {
        log::Warn("rest.route_skipped",
                  log::Fields().Add("method", m->full_name()).Add("reason", "client_streaming"));
        continue;
      }
      if (auto s = AddRoutes(m, m->options().GetExtension(google::api::http), true, routes);
          !s.ok()) {
        return s;
      }
    }
  }
  for (const auto& [path, handler] : options.direct_unary) {
    bool found = false;
    for (Route& route : routes) {
      if (route.grpc_path != path) continue;
      if (route.server_streaming || !handler) {
        return absl::InvalidArgumentError(
            absl::StrCat("rest router: direct handler for ", path, " must be a unary method's"));
      }
      route.direct = handler;
      route.response_prototype =
          pb::MessageFactory::generated_factory()->GetPrototype(route.method->output_type());
      route.json_cache = std::make_shared<JsonCache>();
      found = true;
    }
    if (!found) {
      return absl::InvalidArgumentError(
          absl::StrCat("rest router: direct handler for ", path, ": no route has that method"));
    }
  }
  return std::unique_ptr<Router>(new Router(std::move(options), std::move(routes)));
}

Router::Router(RouterOptions options, std::vector<Route> routes)
    : options_(std::move(options)),
      routes_(std::move(routes)),
      inflight_(std::make_shared<Inflight>()) {
  for (const Route& r : routes_) by_specificity_.push_back(&r);
  std::stable_sort(by_specificity_.begin(), by_specificity_.end(),
                   [](const Route* a, const Route* b) { return a->specificity > b->specificity; });
}

Router::~Router() {
  CancelAll();
  WaitIdle(std::chrono::milliseconds::max());
}

void Router::CancelAll() noexcept {
  std::vector<std::shared_ptr<Call>> calls;
  {
    std::lock_guard lock(inflight_->mu);
    inflight_->stopping = true;
    for (auto& [ptr, call] : inflight_->calls) calls.push_back(call);
  }
  for (auto& call : calls) call->Cancel();  // outside the lock: completions may run inline
}

bool Router::WaitIdle(std::chrono::milliseconds timeout) noexcept {
  std::unique_lock lock(inflight_->mu);
  auto idle = [&] { return inflight_->calls.empty(); };
  if (timeout == std::chrono::milliseconds::max()) {
    inflight_->idle.wait(lock, idle);
    return true;
  }
  return inflight_->idle.wait_for(lock, timeout, idle);
}

void Router::Handle(HttpRequest request, std::shared_ptr<ResponseSink> sink) noexcept {
  try {
    std::string_view target = request.target;
    if (target.empty() || target.front() != '/') {
      sink->OnResponse(ErrorResponse(
          400, kInvalidArgument,
          absl::StrCat("request target must start with '/': ", absl::CHexEscape(Av(target)))));
      return;
    }
    const size_t q = target.find('?');
    const std::string_view path = target.substr(0, q);
    const std::string_view query = q == std::string_view::npos ? "" : target.substr(q + 1);
    if (!IsPercentEncoded(path)) {
      sink->OnResponse(ErrorResponse(
          400, kInvalidArgument,
          absl::StrCat("malformed percent-encoding in path ", absl::CHexEscape(Av(path)))));
      return;
    }
    const std::string& method = request.method;
    if (auto fixed = options_.fixed_routes.find(path); fixed != options_.fixed_routes.end()) {
      if (method != "GET") {
        auto r = ErrorResponse(
            405, kUnimplemented,
            absl::StrCat(method, " ", Av(path), ": method not allowed (allowed: GET)"));
        r.headers.emplace_back("Allow", "GET");
        sink->OnResponse(std::move(r));
      } else {
        sink->OnResponse(fixed->second());
      }
      return;
    }
    if (path == "/openapi.json" || path == "/healthz") {
      if (method != "GET") {
        auto r = ErrorResponse(
            405, kUnimplemented,
            absl::StrCat(method, " ", Av(path), ": method not allowed (allowed: GET)"));
        r.headers.emplace_back("Allow", "GET");
        sink->OnResponse(std::move(r));
      } else if (path == "/healthz") {
        HandleHealth(sink);
      } else if (options_.openapi_json.empty()) {
        sink->OnResponse(ErrorResponse(404, kNotFound, "no OpenAPI document was configured"));
      } else {
        sink->OnResponse(JsonResponse(200, options_.openapi_json));
      }
      return;
    }

    // The most specific matching template wins; when it belongs to another method, 405
    // (Allow lists the methods whose templates match at that rank).
    // Routes are tried most specific first (ties in rule order) and only down to the first
    // fit's rank: the winner is the first fit of this method at that rank (Fits allocates
    // nothing; the winner's variables are bound once, below).
    // A template with a verb fits only paths with that verb (PathVerb): for a drive's GET that
    // skips the ≈ 25 ":verb" routes ranked above it without calling Fits (decision 1364).
    const size_t segments = static_cast<size_t>(std::count(path.begin(), path.end(), '/'));
    const std::string_view verb = PathVerb(path);
    const Route* best = nullptr;
    int top_score = -1;
    for (const Route* route : by_specificity_) {
      if (route->specificity < top_score) break;
      if (segments < route->min_segments || segments > route->max_segments) continue;
      if (!route->path.verb().empty() && route->path.verb() != verb) continue;
      if (!route->path.Fits(path)) continue;
      top_score = route->specificity;
      if (best == nullptr && route->http_method == method) best = route;
    }
    if (best != nullptr) {
      auto bindings = best->path.Match(path);
      if (!bindings) {  // Fits and Match disagree: our bug
        sink->OnResponse(ErrorResponse(500, kInternal, "rest router: path match inconsistent"));
        return;
      }
      HandleApi(*best, *std::move(bindings), query, request, sink);
      return;
    }
    if (top_score >= 0) {
      // Allow: the methods whose templates match at the top rank, sorted and unique.
      std::set<std::string> allowed;
      for (const Route& route : routes_) {
        if (route.specificity == top_score && route.path.Fits(path)) {
          allowed.insert(route.http_method);
        }
      }
      const std::string list = absl::StrJoin(allowed, ", ");
      auto r = ErrorResponse(
          405, kUnimplemented,
          absl::StrCat(method, " ", Av(path), ": method not allowed (allowed: ", list, ")"));
      r.headers.emplace_back("Allow", list);
      sink->OnResponse(std::move(r));
      return;
    }
    if (method == "GET" && !options_.static_dir.empty()) {
      sink->OnResponse(ServeStatic(path));
      return;
    }
    if (method == "GET" && options_.web_assets != nullptr) {
      sink->OnResponse(ServeWebAsset(*options_.web_assets, *PercentDecode(path)));
      return;
    }
    sink->OnResponse(
        ErrorResponse(404, kNotFound, absl::StrCat("no route for ", method, " ", Av(path))));
  } catch (const std::exception& e) {
    sink->OnResponse(ErrorResponse(500, kInternal, absl::StrCat("rest router: ", e.what())));
  }
}

void Router::HandleApi(const Route& route, std::vector<PathBinding> bindings,
                       std::string_view query, HttpRequest& request,
                       const std::shared_ptr<ResponseSink>& sink) noexcept {
  const pb::Descriptor* input = route.method->input_type();
  // The request message lives on an arena whose first block is this frame's, and so does a
  // direct route's response (HandleDirect; decisions 1363, 1364): one arena per request, no
  // heap allocation for the message or its path-bound strings. Nothing keeps the request past
  // this call: the gRPC path serialises it below, the direct path reads it inline.
  alignas(std::max_align_t) char block[kDirectArenaBlock];
  pb::ArenaOptions arena_options;
  arena_options.initial_block = block;
  arena_options.initial_block_size = sizeof(block);
  pb::Arena arena(arena_options);
  pb::Message* msg = route.request_prototype->New(&arena);
  // 400 with "where: what" and, when a field is known, a google.rpc.BadRequest violation.
  auto bad_request = [&](const std::string& where, absl::string_view what, std::string field) {
    sink->OnResponse(ErrorResponse(400, kInvalidArgument, absl::StrCat(where, ": ", what),
                                   std::move(field), std::string(what)));
  };

  // 1. The body: the whole request ("*") or one field of it.
  const bool body_empty = std::all_of(request.body.begin(), request.body.end(), [](char c) {
    return absl::ascii_isspace(static_cast<unsigned char>(c));
  });
  if (!route.body.empty() && !body_empty) {
    pb::util::JsonParseOptions parse;
    std::string wrapped;
    const std::string* json = &request.body;
    if (route.body != "*") {
      wrapped = absl::StrCat("{\"", route.body, "\":", request.body, "}");
      json = &wrapped;
    }
    if (auto s = pb::util::JsonStringToMessage(*json, msg, parse); !s.ok()) {
      JsonError e = SplitJsonError(std::string(s.message()));
      if (route.body != "*") {  // the body was wrapped as {"<field>": ...}
        e.field = e.field.empty() ? route.body : e.field;
      }
      bad_request(e.field.empty() ? "body" : absl::StrCat("body field ", e.field), e.what, e.field);
      return;
    }
  }

  // 2. Path variables; they win over the body. Their fields were resolved in Create (AddRoutes),
  // in the order Match binds them.
  if (bindings.size() != route.variable_fields.size()) {  // Match and the template disagree
    sink->OnResponse(ErrorResponse(500, kInternal, "rest router: path bindings inconsistent"));
    return;
  }
  for (size_t i = 0; i < bindings.size(); ++i) {
    const PathBinding& b = bindings[i];
    if (auto s = SetPath(msg, route.variable_fields[i], b.value); !s.ok()) {
      bad_request(absl::StrCat("path parameter ", b.field_path), s.message(), b.field_path);
      return;
    }
  }

  // 3. Query parameters name the remaining fields (repeated ones may repeat).
  std::set<std::string> seen;
  const std::vector<std::string>& bound = route.variable_names;
  for (absl::string_view pair : absl::StrSplit(Av(query), '&', absl::SkipEmpty())) {
    const size_t eq = pair.find('=');
    auto key = PercentDecode(Sv(pair.substr(0, eq)), false, true);
    auto value =
        PercentDecode(eq == absl::string_view::npos ? "" : Sv(pair.substr(eq + 1)), false, true);
    if (!key || !value) {
      bad_request("query", absl::StrCat("malformed percent-encoding in ", absl::CHexEscape(pair)),
                  "");
      return;
    }
    auto fields = ResolvePath(input, *key);
    if (!fields.ok()) {
      bad_request(absl::StrCat("query parameter ", *key), fields.status().message(), *key);
      return;
    }
    const std::string name = FieldPathName(*fields);
    if (route.body == "*" ||
        (!route.body.empty() && absl::StartsWith(name + ".", route.body + "."))) {
      bad_request(absl::StrCat("query parameter ", *key), "set it in the JSON body instead", *key);
      return;
    }
    if (std::find(bound.begin(), bound.end(), name) != bound.end()) {
      bad_request(absl::StrCat("query parameter ", *key), "bound by the path", *key);
      return;
    }
    if (!fields->back()->is_repeated() && !seen.insert(name).second) {
      bad_request(absl::StrCat("query parameter ", *key), "given twice", *key);
      return;
    }
    if (auto s = SetPath(msg, *fields, *value); !s.ok()) {
      bad_request(absl::StrCat("query parameter ", *key), s.message(), name);
      return;
    }
  }

  // 4. If-Match (RFC 9110 §13.1.1) as the request's `etag` when nothing else set it; the
  // entity tag's quotes and a weak "W/" prefix are dropped (our etags are opaque strings).
  // "*" matches any current representation: no etag check. An empty tag ("" or W/"") is refused:
  // an empty etag means "unconditional" to the services, the opposite of what the client asked.
  if (!request.if_match.empty()) {
    const auto* etag = input->FindFieldByName("etag");
    if (etag != nullptr && !etag->is_repeated() &&
        etag->type() == pb::FieldDescriptor::TYPE_STRING &&
        msg->GetReflection()->GetString(*msg, etag).empty()) {
      absl::string_view tag = absl::StripAsciiWhitespace(Av(request.if_match));
      if (tag != "*") {
        absl::ConsumePrefix(&tag, "W/");
        if (tag.size() >= 2 && tag.front() == '"' && tag.back() == '"') {
          tag = tag.substr(1, tag.size() - 2);
        }
        if (tag.empty()) {
          bad_request("If-Match",
                      "empty entity tag (send the etag the resource was read with, or *)", "etag");
          return;
        }
        msg->GetReflection()->SetString(msg, etag, std::string(tag));
      }
    }
  }

  if (route.direct) {
    HandleDirect(route, *msg, arena, request, sink);
    return;
  }

  std::string bytes;
  if (!msg->SerializeToString(&bytes)) {
    sink->OnResponse(ErrorResponse(500, kInternal, "request serialization failed"));
    return;
  }
  auto ctx = MakeContext(request);
  grpc::GenericStub stub(options_.channel);
  if (route.server_streaming) {
    auto reactor = std::make_shared<StreamReactor>(std::move(ctx), ToByteBuffer(bytes), sink,
                                                   route.method->output_type(), inflight_);
    reactor->Start(stub, route.grpc_path);
    return;
  }
  ctx->set_deadline(std::chrono::system_clock::now() + options_.call_timeout);
  const pb::Descriptor* output = route.method->output_type();
  auto finish = [output, response_body = route.response_body](
                    const grpc::Status& status, const grpc::ByteBuffer& buffer) -> HttpResponse {
    std::unique_ptr<pb::Message> out = NewMessage(output);
    if (status.ok() && !FromByteBuffer(buffer, out.get())) {
      return ErrorResponse(500, kInternal, absl::StrCat("cannot parse ", output->full_name()));
    }
    return UnaryResponse(status, *out, response_body);
  };
  UnaryCall::Start(std::make_shared<UnaryCall>(std::move(ctx), ToByteBuffer(bytes), sink, finish),
                   stub, route.grpc_path, inflight_);
}

void Router::HandleDirect(const Route& route, const pb::Message& in, pb::Arena& arena,
                          const HttpRequest& request, const std::shared_ptr<ResponseSink>& sink) {
  {
    std::lock_guard lock(inflight_->mu);  // the same 503 as a gRPC call refused by Inflight::Add
    if (inflight_->stopping) {
      sink->OnResponse(ErrorResponse(503, kUnavailable, "REST server is stopping"));
      return;
    }
  }
  // The response lives on the request's stack-backed arena (decision 1363): building x1's Drive
  // takes ~15 sub-messages and strings, each a malloc and a free on the heap. Nothing keeps the
  // message: UnaryResponse copies what it prints or caches before the arena goes.
  pb::Message* out = route.response_prototype->New(&arena);
  const grpc::Status status = route.direct(request, in, out);
  sink->OnResponse(UnaryResponse(status, *out, route.response_body, route.json_cache.get()));
}

void Router::HandleHealth(const std::shared_ptr<ResponseSink>& sink) noexcept {
  // A real call proves the channel reaches a live server (an in-process channel has no
  // connectivity state). No health service registered (UNIMPLEMENTED) still proves that.
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + options_.health_timeout);
  auto finish = [](const grpc::Status& status, const grpc::ByteBuffer& buffer) -> HttpResponse {
    if (status.error_code() == grpc::StatusCode::UNIMPLEMENTED) return TextResponse(200, "ok\n");
    if (!status.ok()) {
      return TextResponse(
          503, absl::StrCat("gRPC channel not connected: ", status.error_message(), "\n"));
    }
    // grpc.health.v1.HealthCheckResponse: field 1 (status), varint; SERVING = 1.
    if (BufferBytes(buffer) == std::string("\x08\x01")) return TextResponse(200, "ok\n");
    return TextResponse(503, "gRPC server not serving\n");
  };
  grpc::GenericStub stub(options_.channel);
  UnaryCall::Start(std::make_shared<UnaryCall>(std::move(ctx), ToByteBuffer(""), sink, finish),
                   stub, "/grpc.health.v1.Health/Check", inflight_);
}

HttpResponse Router::ServeStatic(std::string_view path) const {
  auto decoded = PercentDecode(path);
  std::string rel = decoded ? decoded->substr(1) : std::string();
  if (!decoded || rel.find('\0') != std::string::npos || rel.find('\\') != std::string::npos ||
      (!rel.empty() && rel.front() == '/')) {
    return ErrorResponse(400, kInvalidArgument,
                         absl::StrCat("bad static path ", absl::CHexEscape(Av(path))));
  }
  for (absl::string_view seg : absl::StrSplit(rel, '/')) {
    if (seg == "..") {
      return ErrorResponse(
          400, kInvalidArgument,
          absl::StrCat("static path may not contain '..': ", absl::CHexEscape(Av(path))));
    }
  }
  std::filesystem::path file = std::filesystem::path(options_.static_dir) / rel;
  std::error_code ec;
  if (rel.empty() || rel.back() == '/' || std::filesystem::is_directory(file, ec)) {
    file /= "index.html";
  }
  if (!std::filesystem::is_regular_file(file, ec)) {
    return ErrorResponse(404, kNotFound, absl::StrCat("no route or file for GET ", Av(path)));
  }
  const auto size = std::filesystem::file_size(file, ec);
  if (ec || size > kMaxStaticFile) {
    return ErrorResponse(500, kInternal,
                         absl::StrCat("static file too large or unreadable: ", Av(path)));
  }
  std::ifstream in(file, std::ios::binary);
  std::string body(static_cast<size_t>(size), '\0');
  if (!in.read(body.data(), static_cast<std::streamsize>(body.size()))) {
    return ErrorResponse(500, kInternal, absl::StrCat("cannot read static file for ", Av(path)));
  }
  HttpResponse r;
  r.content_type = std::string(ContentTypeFor(file.string()));
  r.body = std::move(body);
  return r;
}

}  // namespace drivegw::rest
