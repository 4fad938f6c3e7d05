// The four roles of issue 7, in rising privilege: each role may do what the ones below it may.
#pragma once

#include <optional>
#include <string_view>

namespace drivegw::auth {

// issue 7 "Roles": viewer (read, watch), operator (motion, enable/disable, acknowledge), engineer
// (parameters, curves, sets, native commands), admin (tokens, configuration). Decision 015.
enum class Role { kViewer = 0, kOperator = 1, kEngineer = 2, kAdmin = 3 };

inline constexpr Role kAllRoles[] = {Role::kViewer, Role::kOperator, Role::kEngineer, Role::kAdmin};

// "viewer", "operator", "engineer", "admin".
std::string_view RoleName(Role role);
// The role called `name` (exact, lower case), or nullopt.
std::optional<Role> ParseRole(std::string_view name);
// True when `have` is `need` or above it.
constexpr bool Satisfies(Role have, Role need) {
  return static_cast<int>(have) >= static_cast<int>(need);
}

}  // namespace drivegw::auth
