#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/webhooks/webhook_url.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// The most webhooks a server posts to.
inline constexpr int kMaxWebhooks = 16;

/// A configured webhook ready to post to: its settings, its URL taken apart, its HMAC key.
struct WebhookTarget {
    v1::Webhook config;
    WebhookUrl url;
    std::string secret;  ///< "" for unsigned requests
};

/// The webhooks of a --webhooks-file (JSON {"webhooks": [soilvol.v1.Webhook...]} with
/// webhook_id, url, secret_file, kinds, container_ids; output fields refused), each secret read
/// from its file (a final newline dropped). InvalidArgument naming the file and the field for
/// anything wrong: a malformed id or URL, a duplicate id, an unknown kind, more than
/// kMaxWebhooks, a secret file that cannot be read or is empty or over 4 KiB.
absl::StatusOr<std::vector<WebhookTarget>> LoadWebhooks(const std::string& path);

/// The same from the file's text; secret files are read relative to the working directory.
absl::StatusOr<std::vector<WebhookTarget>> ParseWebhooks(const std::string& text,
                                                         const std::string& path);

/// Whether `target` takes alerts of this kind and container.
bool Accepts(const WebhookTarget& target, int kind, const std::string& container_id);

}  // namespace soilvol::server
