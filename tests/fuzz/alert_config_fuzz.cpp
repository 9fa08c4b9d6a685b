// libFuzzer: the alert configuration the server reads at start - --alert-rules (JSON of
// soilvol.v1.AlertRules) and --webhooks-file (JSON of {"webhooks": [...]}) - on any bytes. An
// accepted rule set is in range; accepted webhooks have distinct valid ids and parsed URLs.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>

#include "server/handlers/alert_rules.hpp"
#include "server/webhooks/webhook_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    if (const auto rules = soilvol::server::ParseAlertRules(text); rules.ok()) {
        if (rules->refused_scans_in_a_row() < 0 || rules->refused_scans_in_a_row() > 1000 ||
            !(rules->min_scan_observed_share() >= 0.0 && rules->min_scan_observed_share() <= 1.0)) {
            std::abort();
        }
    }
    const auto webhooks = soilvol::server::ParseWebhooks(text, "fuzz");
    if (!webhooks.ok()) return 0;
    if (webhooks->size() > static_cast<std::size_t>(soilvol::server::kMaxWebhooks)) std::abort();
    std::set<std::string> ids;
    for (const auto& target : *webhooks) {
        if (!ids.insert(target.config.webhook_id()).second) std::abort();
        if (target.url.host.empty() || target.url.target.empty() || target.url.target[0] != '/') {
            std::abort();
        }
        if (!target.config.secret_file().empty() && target.secret.empty()) std::abort();
    }
    return 0;
}
