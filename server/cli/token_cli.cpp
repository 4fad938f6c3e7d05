// Token subcommands over the same TokenServiceCore as the API, so the CLI's changes are
// validated and audited alike (principal "cli:<user>", source "local").
#include "server/cli/token_cli.h"

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "server/auth/token_service.h"
#include "server/config/config.h"
#include "server/config/env_overrides.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"

namespace drivegw::cli {
namespace {

constexpr char kUsage[] =
    "usage: drivegw token create --name NAME --role viewer|operator|engineer|admin "
    "[--config FILE]\n"
    "       drivegw token list [--all] [--config FILE]\n"
    "       drivegw token revoke NAME [--config FILE]\n"
    "  Works on data_dir/drivegw.db of the configuration (default ./data), also while the\n"
    "  gateway runs; create prints the token once on stdout.\n";

struct Args {
  std::string command;
  std::string name;
  std::string role;
  std::string config_path;
  bool all = false;
};

// Parses args into `a`; returns an error message ("" when fine).
std::string Parse(int argc, const char* const* args, Args& a) {
  if (argc < 1) return "missing subcommand";
  a.command = args[0];
  for (int i = 1; i < argc; ++i) {
    const std::string arg = args[i];
    auto value = [&](std::string& into) {
      if (i + 1 >= argc) return false;
      into = args[++i];
      return true;
    };
    if (arg == "--name" && a.command == "create") {
      if (!value(a.name)) return "--name needs a value";
    } else if (arg == "--role" && a.command == "create") {
      if (!value(a.role)) return "--role needs a value";
    } else if (arg == "--config") {
      if (!value(a.config_path)) return "--config needs a file";
    } else if (arg == "--all" && a.command == "list") {
      a.all = true;
    } else if (a.command == "revoke" && a.name.empty() && arg.rfind("--", 0) != 0) {
      a.name = arg;
    } else {
      return absl::StrCat("unknown argument '", arg, "'");
    }
  }
  if (a.command == "create" && (a.name.empty() || a.role.empty())) {
    return "create needs --name and --role";
  }
  if (a.command == "revoke" && a.name.empty()) return "revoke needs the token's NAME";
  if (a.command != "create" && a.command != "list" && a.command != "revoke") {
    return absl::StrCat("unknown subcommand '", a.command, "'");
  }
  return "";
}

std::string Time(const google::protobuf::Timestamp& t) {
  if (t.seconds() == 0 && t.nanos() == 0) return "-";
  return google::protobuf::util::TimeUtil::ToString(t);
}

server::CallContext CliContext() {
  server::CallContext c;
  const char* user = std::getenv("USER");
  c.principal = absl::StrCat("cli:", user != nullptr && *user != '\0' ? user : "unknown");
  c.role = "admin";  // whoever can write the database file has every right anyway
  c.source_address = "local";
  c.transport = "cli";
  return c;
}

}  // namespace

bool IsTokenCommand(int argc, const char* const* argv) {
  return argc >= 2 && std::strcmp(argv[1], "token") == 0;
}

int RunTokenCommand(int argc, const char* const* args, std::FILE* out, std::FILE* err) {
  Args a;
  if (std::string problem = Parse(argc, args, a); !problem.empty()) {
    std::fprintf(err, "drivegw token: %s\n%s", problem.c_str(), kUsage);
    return 2;
  }
  // The same file and DRIVEGW_* overrides as the gateway (decision 024), so `docker exec gw
  // drivegw token create ...` works on the container's database without repeating --config.
  const config::EnvLookup env = config::ProcessEnvironment();
  const std::string path = config::ResolveConfigPath(a.config_path, env);
  const std::vector<config::ConfigOverride> overrides = config::OverridesFromEnvironment(env);
  absl::StatusOr<config::GatewayConfig> cfg = config::LoadGatewayConfig(path, overrides);
  if (!cfg.ok()) {
    std::fprintf(err, "drivegw token: config %s: %s\n", path.empty() ? "(default)" : path.c_str(),
                 std::string(cfg.status().message()).c_str());
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(cfg->data_dir, ec);
  const std::string db_path = (std::filesystem::path(cfg->data_dir) / "drivegw.db").string();
  absl::StatusOr<storage::Db> db = storage::Db::Open(db_path);
  absl::Status s = db.ok() ? storage::Migrate(*db) : db.status();
  if (!s.ok()) {
    std::fprintf(err, "drivegw token: %s: %s\n", db_path.c_str(), std::string(s.message()).c_str());
    return 1;
  }
  storage::TokenRepo repo(*db);
  storage::AuditLog audit(*db);
  auth::TokenServiceCore core(repo, &audit);
  const server::CallContext ctx = CliContext();

  if (a.command == "create") {
    v1::CreateTokenRequest req;
    req.set_name(a.name);
    req.set_role(a.role);
    auto created = core.CreateToken(req, ctx);
    if (!created.ok()) {
      std::fprintf(err, "drivegw token create: %s\n",
                   std::string(created.status().message()).c_str());
      return 1;
    }
    std::fprintf(out, "%s\n", created->secret().c_str());
    std::fprintf(err,
                 "drivegw token: created '%s' (role %s, id %s) in %s. The token above is shown "
                 "only now; send it as 'authorization: Bearer <token>'.\n",
                 a.name.c_str(), a.role.c_str(), created->token().id().c_str(), db_path.c_str());
    if (!cfg->auth.enabled) {
      std::fprintf(err,
                   "drivegw token: note: auth is disabled in this configuration "
                   "(auth.enabled: false), so the gateway does not ask for it yet.\n");
    }
    return 0;
  }
  if (a.command == "list") {
    v1::ListTokensRequest req;
    req.set_include_revoked(a.all);
    auto list = core.ListTokens(req, ctx);
    if (!list.ok()) {
      std::fprintf(err, "drivegw token list: %s\n", std::string(list.status().message()).c_str());
      return 1;
    }
    std::fprintf(out, "%-24s %-9s %-16s %-24s %-24s %s\n", "NAME", "ROLE", "ID", "CREATED",
                 "LAST USED", "REVOKED");
    for (const v1::Token& t : list->tokens()) {
      std::fprintf(out, "%-24s %-9s %-16s %-24s %-24s %s\n",
                   t.name().substr(std::strlen("tokens/")).c_str(), t.role().c_str(),
                   t.id().c_str(), Time(t.create_time()).c_str(), Time(t.last_used_time()).c_str(),
                   Time(t.revoke_time()).c_str());
    }
    return 0;
  }
  v1::RevokeTokenRequest req;
  req.set_name(a.name);
  auto revoked = core.RevokeToken(req, ctx);
  if (!revoked.ok()) {
    std::fprintf(err, "drivegw token revoke: %s\n",
                 std::string(revoked.status().message()).c_str());
    return 1;
  }
  std::fprintf(err, "drivegw token: revoked '%s' (id %s); calls presenting it are refused now\n",
               a.name.c_str(), revoked->id().c_str());
  return 0;
}

}  // namespace drivegw::cli
