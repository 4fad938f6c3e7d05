// The one table of issue 7 "Every RPC has one required role": full gRPC method name
// ("/drivegw.v1.DriveService/MoveAbsolute") -> the least role that may call it. A method not in
// the table is refused for every principal (decision 015).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "server/auth/role.h"

namespace drivegw::auth {

// The role `full_method` needs, or nullopt for a method the table does not know (deny).
std::optional<Role> RequiredRole(std::string_view full_method);

// The whole table, ordered by method name (tests walk it; docs list it).
const std::map<std::string, Role, std::less<>>& MethodRoles();

}  // namespace drivegw::auth
