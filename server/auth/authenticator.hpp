#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "server/auth/token_file.hpp"
#include "server/base/watched_file.hpp"

namespace soilvol::server {

/// The scope each RPC of soilvol.v1.SoilVolume needs: get and list need `read`, estimates and
/// opening or closing truck loads `estimate`, what registers, calibrates or deletes `admin`.
/// NotFound for a method this table lacks (a test holds it to the service descriptor).
absl::StatusOr<Scope> RequiredScope(std::string_view method);

struct AuthOptions {
    /// Set: every call but health needs `Authorization: Bearer <token>` whose SHA-256 the file
    /// lists (ParseTokenFile), with the scope the call needs. Read again when it changes.
    std::string tokens_file;
    /// mTLS is on (--tls-client-ca): without a tokens file, a client the TLS layer verified is
    /// authenticated by its certificate and may do everything.
    bool client_certificates = false;
    std::chrono::milliseconds reload_check{1000};  ///< how often the file's stamp is looked at
};

/// Who made a call, for the audit log.
struct Principal {
    std::string name;  ///< the token's name, the certificate's subject, or "anonymous"
    std::string via;   ///< "token", "certificate" or "none"
};

/// Checks the credentials of every call against the scope it needs. Thread-safe.
class Authenticator {
  public:
    /// InvalidArgument naming --auth-tokens-file when the file cannot be read or parsed.
    static absl::StatusOr<std::unique_ptr<Authenticator>> Create(AuthOptions options);

    /// No credentials are asked for.
    bool open() const { return options_.tokens_file.empty() && !options_.client_certificates; }

    /// Whether `authorization` (the header's value) or `tls_identity` (a verified client
    /// certificate's subject, "" without) allows `needed`; `who` names the caller whenever it
    /// is known, also when it may not make the call. Unauthenticated when a token is missing,
    /// malformed or unknown; PermissionDenied when the token lacks the scope. The token is
    /// hashed and compared with every listed hash in constant time.
    absl::Status Authorize(Scope needed, std::string_view authorization,
                           std::string_view tls_identity, Principal* who) const;

  private:
    explicit Authenticator(AuthOptions options);
    /// The tokens now in force, read again when the file changed; a file that no longer parses
    /// keeps the previous tokens (and is logged).
    std::shared_ptr<const std::vector<TokenEntry>> Tokens() const;

    AuthOptions options_;
    mutable std::mutex mutex_;
    mutable WatchedFiles watched_;
    mutable std::shared_ptr<const std::vector<TokenEntry>> tokens_;
};

/// Reads and parses a token file (at most kMaxTokenFileBytes).
absl::StatusOr<std::vector<TokenEntry>> LoadTokenFile(const std::string& path);

}  // namespace soilvol::server
