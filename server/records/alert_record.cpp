#include "server/records/alert_record.hpp"

#include "absl/strings/str_cat.h"

namespace soilvol::server {

absl::Status LostLease(const std::string& webhook_id) {
    return absl::AbortedError(
        absl::StrCat("webhook '", webhook_id, "': another replica holds its lease"));
}

}  // namespace soilvol::server
