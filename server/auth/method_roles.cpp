// Every method of every service in proto/drivegw/v1/*.proto with its role. The split follows
// issue 7 "Roles" (decision 015): reads and watches are viewer; anything that moves a drive or
// changes its power state, and control leases, operator; what changes a drive's configuration
// (parameters, curves, sets, native commands, the wire trace) engineer; tokens and the audit
// trail admin. tests/server/auth checks every method of every proto file against this table.
#include "server/auth/method_roles.h"

namespace drivegw::auth {
namespace {

struct Entry {
  const char* service;
  const char* method;
  Role role;
};

constexpr Role V = Role::kViewer;
constexpr Role O = Role::kOperator;
constexpr Role E = Role::kEngineer;
constexpr Role A = Role::kAdmin;

constexpr Entry kTable[] = {
    // drive.proto
    {"DriveService", "ListDrives", V},
    {"DriveService", "GetDrive", V},
    {"DriveService", "WatchDrives", V},
    {"DriveService", "GetCommand", V},
    {"DriveService", "ReadParameter", V},  // a read; writes are engineer
    {"DriveService", "Enable", O},
    {"DriveService", "Disable", O},
    {"DriveService", "Home", O},
    {"DriveService", "MoveAbsolute", O},
    {"DriveService", "MoveRelative", O},
    {"DriveService", "MoveVelocity", O},
    {"DriveService", "MoveCoordinated", O},
    {"DriveService", "Stop", O},
    {"DriveService", "AcknowledgeFault", O},
    {"DriveService", "StreamCyclicSetpoints", O},  // motion, set point by set point
    {"DriveService", "WriteParameter", E},
    {"DriveService", "SendNativeCommand", E},
    // parameter_sets.proto
    {"ParameterSetService", "ListParameterDefinitions", V},
    {"ParameterSetService", "GetParameterSet", V},
    {"ParameterSetService", "ListParameterSets", V},
    {"ParameterSetService", "ListParameterSetVersions", V},
    {"ParameterSetService", "GetParameterSetVersion", V},
    {"ParameterSetService", "DiffParameterSet", V},  // reads the drive, changes nothing
    {"ParameterSetService", "GetOperation", V},
    {"ParameterSetService", "ListOperations", V},
    {"ParameterSetService", "ExportParameterSet", V},
    {"ParameterSetService", "CreateParameterSet", E},
    {"ParameterSetService", "UpdateParameterSet", E},
    {"ParameterSetService", "DeleteParameterSet", E},
    {"ParameterSetService", "CaptureParameterSet", E},
    {"ParameterSetService", "ApplyParameterSet", E},  // also its dry run: one method, one role
    {"ParameterSetService", "RestoreOperation", E},   // an apply of the pre-image (1441)
    {"ParameterSetService", "ImportParameterSet", E},
    // curve_sets.proto
    {"CurveSetService", "GetCurveSet", V},
    {"CurveSetService", "ListCurveSets", V},
    {"CurveSetService", "ListCurveSetVersions", V},
    {"CurveSetService", "GetCurveSetVersion", V},
    {"CurveSetService", "GetCurvePlot", V},
    {"CurveSetService", "ValidateCurveSet", V},  // computes, writes nothing
    {"CurveSetService", "RunCurve", O},          // motion along a downloaded curve
    {"CurveSetService", "CreateCurveSet", E},
    {"CurveSetService", "UpdateCurveSet", E},
    {"CurveSetService", "DeleteCurveSet", E},
    {"CurveSetService", "DownloadCurve", E},  // writes the drive's curve memory
    // leases.proto: a lease guards motion, so taking one is an operator's act.
    {"LeaseService", "ListLeases", V},
    {"LeaseService", "AcquireLease", O},
    {"LeaseService", "RenewLease", O},
    {"LeaseService", "ReleaseLease", O},
    // ops.proto
    {"OpsService", "GetReadiness", V},
    {"OpsService", "SetWireTrace", E},  // a diagnostic switch on the drive's link
    // audit.proto: who did what from where is security information.
    {"AuditService", "ListAuditEvents", A},
    {"AuditService", "WatchAuditEvents", A},
    {"AuditService", "ExportAuditEvents", A},
    {"AuditService", "VerifyAuditLog", A},
    // auth.proto
    {"TokenService", "CreateToken", A},
    {"TokenService", "ListTokens", A},
    {"TokenService", "RevokeToken", A},
    {"TokenService", "WhoAmI", V},  // the caller's own identity (issue 8 dashboard)
};

}  // namespace

const std::map<std::string, Role, std::less<>>& MethodRoles() {
  static const std::map<std::string, Role, std::less<>> table = [] {
    std::map<std::string, Role, std::less<>> m;
    for (const Entry& e : kTable) {
      m.emplace(std::string("/drivegw.v1.") + e.service + "/" + e.method, e.role);
    }
    return m;
  }();
  return table;
}

std::optional<Role> RequiredRole(std::string_view full_method) {
  const auto& table = MethodRoles();
  auto it = table.find(full_method);
  if (it == table.end()) return std::nullopt;
  return it->second;
}

}  // namespace drivegw::auth
