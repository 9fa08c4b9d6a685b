#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"

/// Returns the status from the enclosing function when `expr` is not OK.
#define SOILVOL_RETURN_IF_ERROR(expr)                      \
    do {                                                   \
        const ::absl::Status soilvol_status_ = (expr);     \
        if (!soilvol_status_.ok()) return soilvol_status_; \
    } while (false)

#define SOILVOL_CONCAT_INNER_(a, b) a##b
#define SOILVOL_CONCAT_(a, b) SOILVOL_CONCAT_INNER_(a, b)

/// Assigns the value of a StatusOr `rexpr` to `lhs`, or returns its status when not OK.
#define SOILVOL_ASSIGN_OR_RETURN(lhs, rexpr) \
    SOILVOL_ASSIGN_OR_RETURN_IMPL_(SOILVOL_CONCAT_(soilvol_statusor_, __LINE__), lhs, rexpr)

#define SOILVOL_ASSIGN_OR_RETURN_IMPL_(statusor, lhs, rexpr) \
    auto statusor = (rexpr);                                 \
    if (!statusor.ok()) return statusor.status();            \
    lhs = std::move(statusor).value()
