// Status propagation macros: abseil 20220623 has Status/StatusOr but no public RETURN_IF_ERROR.
#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"

#define DGW_CONCAT_INNER_(a, b) a##b
#define DGW_CONCAT_(a, b) DGW_CONCAT_INNER_(a, b)

// Returns the status from the enclosing function if `expr` is not OK.
#define DGW_RETURN_IF_ERROR(expr)                  \
  do {                                             \
    ::absl::Status dgw_status_ = (expr);           \
    if (!dgw_status_.ok()) return dgw_status_;     \
  } while (false)

// `DGW_ASSIGN_OR_RETURN(auto x, F());` declares x from an OK StatusOr or returns its status.
#define DGW_ASSIGN_OR_RETURN(lhs, expr) \
  DGW_ASSIGN_OR_RETURN_IMPL_(DGW_CONCAT_(dgw_statusor_, __LINE__), lhs, expr)
#define DGW_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                               \
  if (!tmp.ok()) return tmp.status();              \
  lhs = std::move(tmp).value()
