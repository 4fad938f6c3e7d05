// Gateway: wires configuration, storage, drives, demo simulators, the core, gRPC and REST.
#include "server/gateway.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "adapters/core/log.h"
#include "adapters/core/registry.h"
#include "adapters/core/status.h"
#include "adapters/linmot/devicenet/factory.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/stober/factory.h"
#include "adapters/transport/can_channel.h"
#include "adapters/trinamic/factory.h"
#include "server/core/curve_set_service.h"
#include "server/core/parameter_apply.h"
#include "server/core/audit_service.h"
#include "server/core/drive_event_recorder.h"
#include "server/core/parameter_set_service.h"
#include "server/database_check.h"
#include "server/auth/authenticator.h"
#include "server/auth/token_service.h"
#include "server/grpc/audit_service_grpc.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/curve_set_service_grpc.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/lease_service_grpc.h"
#include "server/grpc/parameter_set_service_grpc.h"
#include "server/grpc/peer_identity.h"
#include "server/grpc/token_service_grpc.h"
#include "server/grpc/worker_pool.h"
#include "server/ops/drive_metrics.h"
#include "server/ops/metrics.h"
#include "server/ops/ops_service_grpc.h"
#include "server/ops/readiness.h"
#include "server/ops/rpc_metrics.h"
#include "server/ops/shutdown.h"
#include "server/rest/direct_reads.h"
#include "server/rest/server.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/server.h"
#include "sim/stober/server.h"
#include "sim/trinamic/server.h"
#include "storage/audit_log.h"
#include "storage/config_repo.h"
#include "storage/curve_set_repo.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "storage/token_repo.h"

namespace drivegw::server {

extern const std::string_view kOpenApiJson;  // generated from proto/ at build time

namespace {
constexpr int kWorkerThreads = 8;
// Services with a grpc.health.v1 status of their own (plus "" for the whole server).
constexpr const char* kHealthServices[] = {"",
                                           "drivegw.v1.DriveService",
                                           "drivegw.v1.ParameterSetService",
                                           "drivegw.v1.CurveSetService",
                                           "drivegw.v1.AuditService",
                                           "drivegw.v1.LeaseService",
                                           "drivegw.v1.OpsService"};

DriveRegistry MakeRegistry() {
  DriveRegistry r;
  r.Register(linmot::linudp::kFamilyName, linmot::linudp::CreateLinMotUdpDrive);
  r.Register(linmot::devicenet::kFamilyName, linmot::devicenet::CreateLinMotDnDrive);
  r.Register(trinamic::kFamilyName, trinamic::CreateTrinamicDrive);
  r.Register(stober::kFamilyName, stober::CreateStoberDrive);
  return r;
}

// Demo: one simulated SIXpack at address 1 with R8 replies (the simulator's default, G-01) on a
// pty whose symlink lives in the data dir, so every gateway instance has its own and a link left
// by a killed run is replaced (PseudoTerminal::Open; decision 406). Its own SteadyClock: the pty
// server advances the controller on real bytes, never on a test's manual clock.
absl::StatusOr<std::unique_ptr<sim::trinamic::TrinamicServer>> StartTrinamicDemo(
    const std::string& pty_path) {
  sim::trinamic::ServerOptions so;
  so.controller.address = 1;
  so.controller.axes = 6;
  so.controller.framing = sim::trinamic::ReplyFraming::kR8;
  so.pty_path = pty_path;
  // Nobody reads the demo's word trace; kept, it grew the gateway by ≈ 1.6 MB per minute up to
  // ≈ 15 MB (found by the soak test, decision 1442).
  so.trace_limit = 0;
  auto server = sim::trinamic::TrinamicServer::Start(so, SteadyClock::Instance());
  if (!server.ok()) {
    return absl::Status(server.status().code(),
                        absl::StrCat("demo drives 'feeder-x'/'feeder-y' simulator: ",
                                     server.status().message()));
  }
  return server;
}

// Demo: the user-space bus of the STOBER axis; never the DeviceNet demo bus (decision 407).
absl::StatusOr<CanBusConfig> DemoCanOpenBus(const GatewayOptions& options) {
  uint32_t port = options.demo_canopen_port;
  if (port == 0) port = options.demo_can_port + 1u;
  if (port > 65535 || port == options.demo_can_port) {
    return absl::InvalidArgumentError(absl::StrCat(
        "demo_canopen_port: ", port, " must be 1..65535 and differ from demo_can_port ",
        options.demo_can_port, " (CANopen and DeviceNet never share a bus, decision 407)"));
  }
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = options.demo_can_group;
  bus.port = static_cast<uint16_t>(port);
  return bus;
}

// Demo STOBER axis's I423 (decision 413): covers the gateway's SYNC jitter and scheduling stalls
// on a loaded host (tens of ms), and a stream that really stops is still cancelled after 0.1 s.
constexpr double kDemoStoberExtrapolationMs = 100;

// Demo: one simulated STOBER axis as CANopen node `drive.node_id` on `drive.can`, with the
// simulator's power-on catalogue (F-LIN: referenced, I50/I51 ±10000 u) that the drive's axis
// limits mirror (decision 409). Its heartbeat starts when the drive writes 1017h. Commissioned
// for a master that is not hard real-time: I423 = 100 ms (decision 413).
absl::StatusOr<std::unique_ptr<sim::stober::AxisServer>> StartStoberDemo(const DriveConfig& drive,
                                                                         const Clock& clock) {
  sim::stober::AxisServerOptions so;
  so.node_id = *drive.node_id;
  so.can = *drive.can;
  so.axis.extrapolation_ms = kDemoStoberExtrapolationMs;
  auto server = sim::stober::AxisServer::Start(so, clock);
  if (!server.ok()) {
    return absl::Status(server.status().code(),
                        absl::StrCat("demo drive '", drive.name,
                                     "' simulator: ", server.status().message()));
  }
  return server;
}

// Start-up (issue 10, P7; docs/performance.md "P7"): drives are activated concurrently, because
// an activation may wait on its drive (a STOBER node's SDO configuration, ~100 ms; a Trinamic
// axis's parameter writes, ~45 ms): 200 drives one after the other took 2.5 s until /readyz.
// Drives sharing one serialised line keep their order in one group: the axes on a Trinamic line or
// bus (one session per line, decision 1052) and the DeviceNet drives of one bus (one session per
// bus). CANopen nodes each have their own SDO channel (adapters/canopen/master.h) and LinUDP peers
// register under their session's lock, so each of those is a group of its own.
std::string ActivationGroup(const DriveConfig& dc) {
  if (dc.trinamic) {
    return dc.trinamic->serial
               ? absl::StrCat("trinamic serial:", dc.trinamic->serial->device)
               : absl::StrCat("trinamic ", transport::CanSpecString(*dc.trinamic->can));
  }
  if (dc.family == linmot::devicenet::kFamilyName && dc.can) {
    return absl::StrCat("devicenet ", transport::CanSpecString(*dc.can));
  }
  return absl::StrCat("drive ", dc.name);
}

constexpr size_t kActivationThreads = 16;

// Activates every drive, groups in parallel (each group in configuration order), marking each
// drive tried for /readyz as it finishes; the first error in configuration order is returned,
// after every activation has ended.
absl::Status ActivateAll(const std::vector<std::unique_ptr<Drive>>& drives,
                         ops::Readiness& readiness) {
  std::vector<std::vector<size_t>> groups;
  std::map<std::string, size_t> group_of;
  for (size_t i = 0; i < drives.size(); ++i) {
    const auto [it, added] = group_of.emplace(ActivationGroup(drives[i]->config()), groups.size());
    if (added) groups.emplace_back();
    groups[it->second].push_back(i);
  }
  std::vector<absl::Status> results(drives.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t g = next++; g < groups.size(); g = next++) {
      for (size_t i : groups[g]) {
        results[i] = drives[i]->Activate();
        readiness.MarkDriveTried(drives[i]->config().name);
      }
    }
  };
  std::vector<std::thread> threads;
  for (size_t t = 1; t < std::min(kActivationThreads, groups.size()); ++t)
    threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
  for (const absl::Status& s : results) DGW_RETURN_IF_ERROR(s);
  return absl::OkStatus();
}

}  // namespace

struct Gateway::Impl {
  const Clock* clock = nullptr;
  std::unique_ptr<storage::Db> db;
  std::unique_ptr<storage::AuditLog> audit;
  // Authentication (issue 7, decision 015): the one enforcement point every service's calls
  // pass; declared before the worker pool and the services that use it.
  std::unique_ptr<storage::TokenRepo> tokens;
  std::unique_ptr<auth::Authenticator> authenticator;
  std::unique_ptr<CallAuth> call_auth;
  std::unique_ptr<auth::TokenServiceCore> token_core;
  std::map<std::string, std::unique_ptr<sim::linmot::LinMotServer>> sims;
  std::map<std::string, std::unique_ptr<sim::linmot_devicenet::LinMotDnServer>> dn_sims;
  std::unique_ptr<sim::trinamic::TrinamicServer> trinamic_sim;
  std::unique_ptr<sim::stober::AxisServer> stober_sim;
  std::vector<std::shared_ptr<Drive>> drives;
  // Audit trail (issue 7, decision 017): drive-side events and AuditService; after the drives and
  // the audit log they use, so destroyed before them.
  std::unique_ptr<DriveEventRecorder> drive_events;
  std::unique_ptr<AuditServiceCore> audit_core;
  std::unique_ptr<AuditServiceGrpc> audit_service;
  // Control leases and idempotent retries (issue 7, decisions 019, 020), used by the cores and
  // services below, so declared before them.
  std::unique_ptr<LeaseManager> leases = std::make_unique<LeaseManager>();
  std::unique_ptr<IdempotencyCache> idempotency = std::make_unique<IdempotencyCache>();
  std::unique_ptr<DriveServiceCore> core;
  std::unique_ptr<WorkerPool> pool;
  std::unique_ptr<DriveServiceGrpc> service;
  // Parameter sets (issue 6): declared after the drives and the audit log they use, so the
  // applier (which waits for running operations) is destroyed before them.
  CatalogueList catalogues;
  std::unique_ptr<storage::ParameterSetRepo> parameter_sets;
  std::unique_ptr<ParameterApplier> applier;
  std::unique_ptr<ParameterSetServiceCore> parameter_set_core;
  std::unique_ptr<ParameterSetServiceGrpc> parameter_set_service;
  // Curve sets (issue 6, decision 014): store, core and gRPC service.
  std::unique_ptr<storage::CurveSetRepo> curve_sets;
  std::unique_ptr<CurveSetServiceCore> curve_set_core;
  std::unique_ptr<CurveSetServiceGrpc> curve_set_service;
  std::unique_ptr<TokenServiceGrpc> token_service;
  std::unique_ptr<LeaseServiceCore> lease_core;
  std::unique_ptr<LeaseServiceGrpc> lease_service;
  // Per-RPC metrics (decision 021), shared by the gRPC interceptor and REST's direct reads
  // (decision 1331); outlives both servers.
  std::unique_ptr<ops::RpcMetrics> rpc_metrics;
  std::unique_ptr<grpc::Server> grpc_server;
  int grpc_port = 0;
  std::unique_ptr<rest::RestServer> rest;
  bool stopped = false;
  // Operations (issue 7, decisions 021, 022): readiness for /readyz and OpsService, the drive
  // metrics collector (removed at Stop), the wire trace switch.
  ops::Readiness readiness;
  int drive_collector = 0;
  std::unique_ptr<OpsServiceCore> ops_core;
  std::unique_ptr<OpsServiceGrpc> ops_service;
};

absl::StatusOr<std::pair<std::string, uint16_t>> SplitHostPort(const std::string& field, const std::string& value) {
  const auto colon = value.rfind(':');
  uint32_t port = 0;
  if (colon == std::string::npos || !absl::SimpleAtoi(value.substr(colon + 1), &port) || port > 65535) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": '", value, "' is not host:port (port 0..65535)"));
  }
  std::string host = value.substr(0, colon);
  if (host.empty()) host = "0.0.0.0";
  return std::make_pair(host, static_cast<uint16_t>(port));
}

namespace {

// Tokens, the authenticator (with tls.client_principals as certificate principals) and the
// enforcement point; with auth disabled, WARN lines saying so (main.cpp adds a banner).
absl::Status StartAuth(const config::GatewayConfig& cfg, Gateway::Impl& impl) {
  impl.tokens = std::make_unique<storage::TokenRepo>(*impl.db);
  auth::AuthOptions options;
  options.enabled = cfg.auth.enabled;
  if (cfg.tls) {
    for (const config::TlsClientPrincipal& p : cfg.tls->client_principals) {
      const std::optional<auth::Role> role = auth::ParseRole(p.role);
      if (!role) {
        return absl::InvalidArgumentError(absl::StrCat("tls.client_principals: role '", p.role,
                                                       "' of '", p.common_name, "' is not a role"));
      }
      options.certificates.push_back({p.common_name, p.principal, *role});
    }
  }
  impl.authenticator = std::make_unique<auth::Authenticator>(std::move(options), impl.tokens.get());
  impl.call_auth = std::make_unique<CallAuth>(*impl.authenticator, impl.audit.get());
  impl.token_core = std::make_unique<auth::TokenServiceCore>(*impl.tokens, impl.audit.get());
  if (!cfg.auth.enabled) {
    log::Warn("auth_disabled", log::Fields()
                                   .Add("principal", "anonymous")
                                   .Add("role", "admin")
                                   .Add("insecure", cfg.auth.insecure ? "true" : "false")
                                   .Add("grpc", cfg.listen.grpc)
                                   .Add("http", cfg.listen.http));
    log::Warn("auth_disabled", log::Fields().Add(
                                   "hint", "set auth.enabled: true and create tokens with "
                                           "'drivegw token create' (docs/config.md)"));
  }
  return absl::OkStatus();
}

}  // namespace

Gateway::Gateway(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Gateway::~Gateway() { Stop(); }

absl::StatusOr<std::unique_ptr<Gateway>> Gateway::Start(GatewayOptions options, const Clock& clock) {
  auto impl = std::make_unique<Impl>();
  impl->clock = &clock;
  config::GatewayConfig& cfg = options.config;
  // Also for configurations built in code: no open gateway beyond loopback (decision 015).
  DGW_RETURN_IF_ERROR(config::CheckListenExposure(cfg.auth, cfg.listen.grpc, cfg.listen.http));

  // Storage first: a gateway that cannot audit does not start.
  std::error_code ec;
  // "data_dir: …" so drivegw can name DRIVEGW_DATA_DIR when the value came from there (1493).
  if (std::filesystem::exists(cfg.data_dir, ec) && !std::filesystem::is_directory(cfg.data_dir, ec)) {
    return absl::FailedPreconditionError(
        absl::StrCat("data_dir: '", cfg.data_dir, "' exists and is not a directory"));
  }
  std::filesystem::create_directories(cfg.data_dir, ec);
  if (ec) return absl::FailedPreconditionError(absl::StrCat("data_dir: cannot create '", cfg.data_dir, "': ", ec.message()));
  const std::string db_path = (std::filesystem::path(cfg.data_dir) / "drivegw.db").string();
  const storage::Durability durability =
      cfg.storage.durability == config::StorageConfig::Durability::kPowerLoss
          ? storage::Durability::kPowerLoss
          : storage::Durability::kProcessCrash;
  // A damaged file stops the start here, named, before anything is written (decision 1495).
  DGW_ASSIGN_OR_RETURN(storage::Db db, OpenCheckedDatabase(db_path, durability));
  impl->db = std::make_unique<storage::Db>(std::move(db));
  DGW_RETURN_IF_ERROR(storage::Migrate(*impl->db));
  impl->audit = std::make_unique<storage::AuditLog>(*impl->db);
  DGW_RETURN_IF_ERROR(impl->audit->SetRetention(
      {cfg.audit.max_entries, cfg.audit.warn_at_percent, cfg.audit.prune_to_percent}));
  impl->readiness.SetStorageOpen(true);
  DGW_RETURN_IF_ERROR(StartAuth(cfg, *impl));

  // Demo mode: embedded simulated drives on loopback, and drive configs pointing at them.
  std::vector<DriveConfig> drive_configs = cfg.drives;
  if (cfg.demo) {
    // Checked before any simulator starts.
    DGW_ASSIGN_OR_RETURN(const CanBusConfig canopen_bus, DemoCanOpenBus(options));
    drive_configs = config::DemoDrives(options.demo_first_port == 0 ? 49360 : options.demo_first_port);
    for (size_t i = 0; i < drive_configs.size(); ++i) {
      DriveConfig& dc = drive_configs[i];
      sim::linmot::SimOptions so;
      so.name = dc.name;
      DGW_ASSIGN_OR_RETURN(so.bind, transport::Endpoint::Parse(dc.linudp->host, options.demo_first_port == 0 ? 0 : dc.linudp->port));
      so.master_port = options.demo_master_port;
      so.stroke_min_mm = dc.axis.min_mm;
      so.stroke_max_mm = dc.axis.max_mm;
      auto server = sim::linmot::LinMotServer::Start(so, clock);
      if (!server.ok()) {
        return absl::Status(server.status().code(),
                            absl::StrCat("demo drive '", dc.name, "' simulator: ", server.status().message()));
      }
      dc.linudp->port = (*server)->port();
      dc.linudp->master_port = options.demo_master_port;
      impl->sims[dc.name] = std::move(*server);
    }
    // One LinMot DeviceNet drive on the user-space CAN bus (issue 3): MAC ID 5, gateway MAC 0.
    DriveConfig dn;
    dn.name = "d1";
    dn.family = "linmot-devicenet";
    dn.axis.min_mm = 0;
    dn.axis.max_mm = 150;
    dn.axis.max_velocity_mm_s = 1000;
    dn.axis.max_acceleration_mm_s2 = 10000;
    CanBusConfig bus;
    bus.kind = CanBusConfig::Kind::kUdpMulticast;
    bus.group = options.demo_can_group;
    bus.port = options.demo_can_port;
    dn.can = bus;
    dn.mac_id = 5;
    sim::linmot_devicenet::DnSimOptions dso;
    dso.name = dn.name;
    dso.can = bus;
    dso.mac_id = *dn.mac_id;
    auto dn_server = sim::linmot_devicenet::LinMotDnServer::Start(dso, clock);
    if (!dn_server.ok()) {
      return absl::Status(dn_server.status().code(),
                          absl::StrCat("demo drive '", dn.name, "' simulator: ", dn_server.status().message()));
    }
    impl->dn_sims[dn.name] = std::move(*dn_server);
    drive_configs.push_back(std::move(dn));

    // Two axes of one simulated Trinamic SIXpack on a serial line (issue 4).
    // Absolute, so the link the drive opens does not depend on the working directory.
    const std::string pty_path =
        (std::filesystem::absolute(cfg.data_dir, ec) / "trinamic-demo.pty").string();
    if (ec) {
      return absl::FailedPreconditionError(
          absl::StrCat("data_dir: cannot resolve '", cfg.data_dir, "': ", ec.message()));
    }
    DGW_ASSIGN_OR_RETURN(impl->trinamic_sim, StartTrinamicDemo(pty_path));
    for (DriveConfig& feeder : config::DemoTrinamicDrives(pty_path)) {
      drive_configs.push_back(std::move(feeder));
    }

    // One simulated STOBER axis, CANopen node 3, on a user-space bus of its own (issue 5).
    DriveConfig s1 = config::DemoStoberDrive(canopen_bus);
    DGW_ASSIGN_OR_RETURN(impl->stober_sim, StartStoberDemo(s1, clock));
    drive_configs.push_back(std::move(s1));
  }

  // One configuration snapshot per start, so the audit trail knows what was running.
  storage::ConfigRepo repo(*impl->db);
  if (auto s = repo.SaveSnapshot(cfg.demo ? "demo" : "config", cfg.source_yaml, static_cast<int>(drive_configs.size()));
      !s.ok()) {
    return s.status();
  }

  const DriveRegistry registry = MakeRegistry();
  std::vector<std::string> drive_names;
  for (const DriveConfig& dc : drive_configs) drive_names.push_back(dc.name);
  impl->readiness.ExpectDrives(drive_names);
  std::vector<std::unique_ptr<Drive>> created;
  for (const DriveConfig& dc : drive_configs) {
    DGW_ASSIGN_OR_RETURN(std::unique_ptr<Drive> drive, registry.Create(dc, clock));
    created.push_back(std::move(drive));
  }
  // A drive that is switched off is OFFLINE, not a start failure; a bad transport is.
  DGW_RETURN_IF_ERROR(ActivateAll(created, impl->readiness));
  for (auto& drive : created) impl->drives.push_back(std::move(drive));
  impl->core =
      std::make_unique<DriveServiceCore>(impl->drives, impl->audit.get(), impl->leases.get());
  impl->pool = std::make_unique<WorkerPool>(kWorkerThreads);
  impl->service = std::make_unique<DriveServiceGrpc>(*impl->core, *impl->pool, *impl->call_auth,
                                                     impl->idempotency.get());
  impl->catalogues = {linmot::linudp::LinMotParameterCatalogue(),
                      linmot::devicenet::LinMotDevicenetParameterCatalogue(),
                      trinamic::TrinamicParameterCatalogue(), stober::StoberParameterCatalogue()};
  impl->parameter_sets = std::make_unique<storage::ParameterSetRepo>(*impl->db);
  impl->applier = std::make_unique<ParameterApplier>(*impl->parameter_sets, impl->catalogues);
  impl->parameter_set_core = std::make_unique<ParameterSetServiceCore>(
      *impl->parameter_sets, *impl->applier, impl->catalogues, impl->drives, impl->audit.get(),
      impl->leases.get());
  // Before the API serves: an apply the previous process did not finish is INTERRUPTED, with
  // its pre-images kept for RestoreOperation (issue 11 "Crash safety", decision 1441).
  DGW_ASSIGN_OR_RETURN(const int interrupted, impl->parameter_set_core->MarkInterrupted());
  if (interrupted > 0) {
    log::Warn("apply_interrupted", log::Fields().Add("operations", interrupted));
  }
  impl->parameter_set_service = std::make_unique<ParameterSetServiceGrpc>(
      *impl->parameter_set_core, *impl->pool, *impl->call_auth, impl->idempotency.get());
  impl->curve_sets = std::make_unique<storage::CurveSetRepo>(*impl->db);
  impl->curve_set_core =
      std::make_unique<CurveSetServiceCore>(*impl->curve_sets, impl->drives, impl->audit.get(),
                                            impl->leases.get());
  impl->curve_set_service = std::make_unique<CurveSetServiceGrpc>(
      *impl->curve_set_core, *impl->pool, *impl->call_auth, impl->idempotency.get());
  impl->lease_core =
      std::make_unique<LeaseServiceCore>(*impl->leases, impl->drives, impl->audit.get());
  impl->lease_service = std::make_unique<LeaseServiceGrpc>(
      *impl->lease_core, *impl->pool, *impl->call_auth, impl->idempotency.get());
  impl->token_service =
      std::make_unique<TokenServiceGrpc>(*impl->token_core, *impl->pool, *impl->call_auth);

  impl->drive_events = std::make_unique<DriveEventRecorder>(impl->drives, impl->audit.get());
  impl->audit_core = std::make_unique<AuditServiceCore>(*impl->audit);
  impl->audit_service = std::make_unique<AuditServiceGrpc>(*impl->audit_core, *impl->pool, *impl->call_auth);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  impl->ops_core =
      std::make_unique<OpsServiceCore>(impl->drives, impl->audit.get(), impl->readiness);
  impl->ops_service =
      std::make_unique<OpsServiceGrpc>(*impl->ops_core, *impl->pool, *impl->call_auth);
  ops::InstallRoundTripHistograms();
  impl->drive_collector = ops::AddDriveCollector(ops::DefaultRegistry(), impl->drives);
  grpc::ServerBuilder builder;
  // Explicit message limits instead of gRPC's implicit ones (decision 1492).
  static_assert(rest::kDefaultBodyLimit <= static_cast<size_t>(kGrpcMaxMessageBytes),
                "a REST body the HTTP front end accepts must pass the in-process gRPC hop");
  builder.SetMaxReceiveMessageSize(kGrpcMaxMessageBytes);
  builder.SetMaxSendMessageSize(kGrpcMaxMessageBytes);
  {
    // Per-RPC metrics on every call, REST's in-process ones included (decision 021).
    std::map<std::string, std::string> families;
    for (const auto& d : impl->drives) families[d->config().name] = d->config().family;
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
    std::set<std::string, std::less<>> raw_methods(std::begin(DriveServiceGrpc::kRawMethods),
                                                   std::end(DriveServiceGrpc::kRawMethods));
    impl->rpc_metrics = std::make_unique<ops::RpcMetrics>(ops::DefaultRegistry(), std::move(families),
                                                          std::move(raw_methods));
    creators.push_back(ops::MakeRpcMetricsFactory(*impl->rpc_metrics));
    builder.experimental().SetInterceptorCreators(std::move(creators));
  }
  DGW_ASSIGN_OR_RETURN(auto grpc_addr, SplitHostPort("listen.grpc", cfg.listen.grpc));
  // TLS (and client certificates) on the network port only; the REST front end's in-process
  // channel below never passes through it (decision 023).
  builder.AddListeningPort(absl::StrCat(grpc_addr.first, ":", grpc_addr.second), GrpcServerCredentials(cfg.tls),
                           &impl->grpc_port);
  builder.RegisterService(impl->service.get());
  builder.RegisterService(impl->parameter_set_service.get());
  builder.RegisterService(impl->curve_set_service.get());
  builder.RegisterService(impl->token_service.get());
  builder.RegisterService(impl->audit_service.get());
  builder.RegisterService(impl->lease_service.get());
  builder.RegisterService(impl->ops_service.get());
  impl->grpc_server = builder.BuildAndStart();
  if (impl->grpc_server == nullptr || impl->grpc_port == 0) {
    return absl::UnavailableError(absl::StrCat("listen.grpc: cannot listen on ", cfg.listen.grpc));
  }
  // gRPC health per service (grpc.health.v1): SERVING now, NOT_SERVING from shutdown on.
  if (auto* health = impl->grpc_server->GetHealthCheckService()) {
    for (const char* service : kHealthServices) health->SetServingStatus(service, true);
  }

  DGW_ASSIGN_OR_RETURN(auto http_addr, SplitHostPort("listen.http", cfg.listen.http));
  rest::RestOptions ro;
  ro.listen_address = http_addr.first;
  ro.port = http_addr.second;
  {
    // The REST front end is a gRPC client: without these its channel keeps the 4 MiB default and
    // a reply the server may send (a large curve set) would fail on the way back (decision 1492).
    grpc::ChannelArguments in_process;
    in_process.SetMaxReceiveMessageSize(kGrpcMaxMessageBytes);
    in_process.SetMaxSendMessageSize(kGrpcMaxMessageBytes);
    ro.channel = impl->grpc_server->InProcessChannel(in_process);
  }
  ro.openapi_json = std::string(kOpenApiJson);
  ro.more_services = {"drivegw.v1.ParameterSetService", "drivegw.v1.CurveSetService"};
  ro.more_services.push_back("drivegw.v1.TokenService");
  ro.more_services.push_back("drivegw.v1.AuditService");
  ro.more_services.push_back("drivegw.v1.LeaseService");
  ro.static_dir = options.static_dir;
  ro.more_services.push_back("drivegw.v1.OpsService");
  ro.fixed_routes["/metrics"] = [] {
    rest::HttpResponse r;
    r.content_type = "text/plain; version=0.0.4; charset=utf-8";
    r.body = ops::DefaultRegistry().Render();
    return r;
  };
  ro.fixed_routes["/readyz"] = [readiness = &impl->readiness] {
    rest::HttpResponse r;
    r.content_type = "text/plain; charset=utf-8";
    const absl::Status s = readiness->Check();
    r.status = s.ok() ? 200 : 503;
    r.body = s.ok() ? "ready\n" : absl::StrCat("not ready: ", s.message(), "\n");
    return r;
  };
  // Read-only unary GETs straight into the core on the Beast thread, through the same CallAuth
  // and RPC metrics (decision 1331, amending 501).
  if (options.rest_direct_reads) {
    ro.direct_unary = rest::DriveServiceDirectReads(*impl->core, *impl->call_auth, *impl->rpc_metrics);
  }
  if (cfg.tls) {
    ro.tls = rest::RestTls{cfg.tls->cert_pem, cfg.tls->key_pem, cfg.tls->client_ca_pem, cfg.tls->require_client_cert};
  }
  auto rest = rest::RestServer::Start(std::move(ro));
  if (!rest.ok()) {
    return absl::Status(rest.status().code(), absl::StrCat("listen.http: ", rest.status().message()));
  }
  impl->rest = std::move(*rest);

  log::Info("gateway_started", log::Fields()
                                   .Add("grpc_port", impl->grpc_port)
                                   .Add("http_port", impl->rest->port())
                                   .Add("drives", impl->drives.size())
                                   .Add("demo", cfg.demo ? "true" : "false")
                                   .Add("auth", cfg.auth.enabled ? "on" : "off")
                                   .Add("tls", !cfg.tls                         ? "off"
                                               : cfg.tls->client_ca_pem.empty() ? "on"
                                               : cfg.tls->require_client_cert   ? "mtls-required"
                                                                                : "mtls-optional")
                                   .Add("db", db_path));
  return std::unique_ptr<Gateway>(new Gateway(std::move(impl)));
}

uint16_t Gateway::grpc_port() const { return static_cast<uint16_t>(impl_->grpc_port); }
uint16_t Gateway::http_port() const { return impl_->rest ? impl_->rest->port() : 0; }
DriveServiceCore& Gateway::core() { return *impl_->core; }

sim::linmot::LinMotServer* Gateway::demo_simulator(const std::string& drive) const {
  auto it = impl_->sims.find(drive);
  return it == impl_->sims.end() ? nullptr : it->second.get();
}

sim::linmot_devicenet::LinMotDnServer* Gateway::demo_devicenet_simulator(const std::string& drive) const {
  auto it = impl_->dn_sims.find(drive);
  return it == impl_->dn_sims.end() ? nullptr : it->second.get();
}

sim::trinamic::TrinamicServer* Gateway::demo_trinamic_simulator() const { return impl_->trinamic_sim.get(); }

sim::stober::AxisServer* Gateway::demo_stober_simulator() const { return impl_->stober_sim.get(); }

void Gateway::BeginShutdown() {
  if (!impl_) return;
  impl_->readiness.SetShuttingDown();
  if (impl_->grpc_server) {
    if (auto* health = impl_->grpc_server->GetHealthCheckService()) {
      for (const char* service : kHealthServices) health->SetServingStatus(service, false);
    }
  }
}

bool Gateway::Shutdown(std::chrono::milliseconds bound) {
  if (!impl_ || impl_->stopped) return true;
  const auto start = std::chrono::steady_clock::now();
  log::Info("shutdown_started", log::Fields().Add("bound_ms", bound.count()));
  BeginShutdown();
  // No new calls: streams end, REST stops accepting, gRPC refuses new calls and gives running
  // ones a quarter of the bound (at most 2 s) before cancelling them.
  if (impl_->core) impl_->core->Shutdown();
  if (impl_->audit_core) impl_->audit_core->Shutdown();
  if (impl_->rest) impl_->rest->Stop();
  if (impl_->grpc_server) {
    const std::chrono::milliseconds grace =
        std::min<std::chrono::milliseconds>(bound / 4, std::chrono::seconds(2));
    impl_->grpc_server->Shutdown(std::chrono::system_clock::now() + grace);
  }
  // Moving axes get a controlled stop; up to 60 % of the bound from the start (decision 022).
  const ops::StopReport report =
      ops::StopMovingDrives(impl_->drives, start + bound * 6 / 10, impl_->audit.get());
  Stop();
  // Every writer is gone: the WAL is copied into the database file and synced (flush), the
  // database closes with the Gateway.
  if (impl_->db) {
    if (absl::Status s = impl_->db->Exec("PRAGMA wal_checkpoint(TRUNCATE)"); !s.ok()) {
      log::Error("shutdown_checkpoint_failed", log::Fields().Add("error", s.message()));
    }
  }
  const auto took =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
  log::Info("shutdown_done", log::Fields()
                                 .Add("stopped", absl::StrJoin(report.stopped, ","))
                                 .Add("still_moving", absl::StrJoin(report.still_moving, ","))
                                 .Add("took_ms", took.count()));
  return report.still_moving.empty();
}

void Gateway::Stop() {
  if (!impl_ || impl_->stopped) return;
  impl_->stopped = true;
  BeginShutdown();
  if (impl_->drive_collector != 0) {
    ops::DefaultRegistry().RemoveCollector(impl_->drive_collector);
    impl_->drive_collector = 0;
  }
  if (impl_->core) impl_->core->Shutdown();  // ends watch streams
  if (impl_->audit_core) impl_->audit_core->Shutdown();  // ends audit watch streams
  if (impl_->rest) impl_->rest->Stop();
  if (impl_->grpc_server) impl_->grpc_server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  if (impl_->pool) impl_->pool->Shutdown();
  if (impl_->drive_events) impl_->drive_events->Stop();
  for (auto& d : impl_->drives) d->Deactivate();
  for (auto& [name, sim] : impl_->sims) sim->Stop();
  for (auto& [name, sim] : impl_->dn_sims) sim->Stop();
  if (impl_->trinamic_sim) impl_->trinamic_sim->Stop();
  if (impl_->stober_sim) impl_->stober_sim->Stop();
  log::Info("gateway_stopped");
}

}  // namespace drivegw::server
