#include "server/webhooks/webhook_config.hpp"

#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "server/base/watched_file.hpp"

namespace soilvol::server {
namespace {

constexpr std::size_t kMaxConfigBytes = 1 << 20;
constexpr std::size_t kMaxSecretBytes = 4096;
constexpr std::size_t kMaxContainerFilters = 256;

bool ValidWebhookId(const std::string& id) {
    if (id.empty() || id.size() > 63 || !absl::ascii_islower(id[0])) return false;
    for (const char c : id) {
        if (!absl::ascii_islower(c) && !absl::ascii_isdigit(c) && c != '-') return false;
    }
    return true;
}

/// The checks of one webhook; `field` names it ("webhooks[0]").
absl::Status CheckWebhook(const v1::Webhook& webhook, const std::string& field) {
    if (!ValidWebhookId(webhook.webhook_id())) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".webhook_id: '", webhook.webhook_id(),
                         "' is not 1-63 characters of [a-z0-9-] starting with a letter"));
    }
    for (const int kind : webhook.kinds()) {
        if (kind == v1::ALERT_KIND_UNSPECIFIED || !v1::AlertKind_IsValid(kind)) {
            return absl::InvalidArgumentError(absl::StrCat(field, ".kinds: unknown kind ", kind));
        }
    }
    if (static_cast<std::size_t>(webhook.container_ids_size()) > kMaxContainerFilters) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".container_ids: at most ", kMaxContainerFilters));
    }
    v1::Webhook settings_only = webhook;
    for (const int number : {1, 2, 3, 4, 5}) {
        settings_only.GetReflection()->ClearField(
            &settings_only, v1::Webhook::descriptor()->FindFieldByNumber(number));
    }
    if (settings_only.ByteSizeLong() != 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            field, ": only webhook_id, url, secret_file, kinds and container_ids are settings"));
    }
    return absl::OkStatus();
}

absl::StatusOr<std::string> ReadSecret(const std::string& path, const std::string& field) {
    absl::StatusOr<std::string> secret = ReadSmallFile(path, kMaxSecretBytes, field);
    if (!secret.ok()) return absl::InvalidArgumentError(secret.status().message());
    if (!secret->empty() && secret->back() == '\n') secret->pop_back();
    if (!secret->empty() && secret->back() == '\r') secret->pop_back();
    if (secret->empty()) {
        return absl::InvalidArgumentError(absl::StrCat(field, ": '", path, "' is empty"));
    }
    return secret;
}

}  // namespace

absl::StatusOr<std::vector<WebhookTarget>> LoadWebhooks(const std::string& path) {
    absl::StatusOr<std::string> text = ReadSmallFile(path, kMaxConfigBytes, "--webhooks-file");
    if (!text.ok()) return absl::InvalidArgumentError(text.status().message());
    return ParseWebhooks(*text, path);
}

absl::StatusOr<std::vector<WebhookTarget>> ParseWebhooks(const std::string& text,
                                                         const std::string& path) {
    const std::string where = absl::StrCat("--webhooks-file ", path);
    v1::ListWebhooksResponse file;
    if (auto parsed = google::protobuf::util::JsonStringToMessage(text, &file); !parsed.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": not JSON of {\"webhooks\": [soilvol.v1.Webhook...]}: ",
                         std::string(parsed.message())));
    }
    if (file.webhooks_size() > kMaxWebhooks) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": at most ", kMaxWebhooks, " webhooks"));
    }
    std::vector<WebhookTarget> out;
    std::set<std::string> ids;
    for (int i = 0; i < file.webhooks_size(); ++i) {
        const v1::Webhook& webhook = file.webhooks(i);
        const std::string field = absl::StrCat(where, ": webhooks[", i, "]");
        if (absl::Status checked = CheckWebhook(webhook, field); !checked.ok()) return checked;
        if (!ids.insert(webhook.webhook_id()).second) {
            return absl::InvalidArgumentError(
                absl::StrCat(field, ".webhook_id: '", webhook.webhook_id(), "' twice"));
        }
        WebhookTarget target;
        target.config = webhook;
        absl::StatusOr<WebhookUrl> url = ParseWebhookUrl(webhook.url());
        if (!url.ok()) {
            return absl::InvalidArgumentError(
                absl::StrCat(field, ".url: ", url.status().message()));
        }
        target.url = *std::move(url);
        if (!webhook.secret_file().empty()) {
            absl::StatusOr<std::string> secret =
                ReadSecret(webhook.secret_file(), field + ".secret_file");
            if (!secret.ok()) return secret.status();
            target.secret = *std::move(secret);
        }
        out.push_back(std::move(target));
    }
    return out;
}

bool Accepts(const WebhookTarget& target, int kind, const std::string& container_id) {
    const v1::Webhook& config = target.config;
    bool kind_ok = config.kinds_size() == 0;
    for (const int k : config.kinds()) kind_ok = kind_ok || k == kind;
    bool container_ok = config.container_ids_size() == 0;
    for (const std::string& id : config.container_ids()) {
        container_ok = container_ok || id == container_id;
    }
    return kind_ok && container_ok;
}

}  // namespace soilvol::server
