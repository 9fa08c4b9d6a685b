#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"
#include "server/base/watched_file.hpp"
#include "server/http/http_server.hpp"

namespace boost::asio::ssl {
class context;
}  // namespace boost::asio::ssl
struct ssl_st;

namespace soilvol::server {

/// A TLS server context from the files (TLS 1.2 and later; client certificates required when
/// a client CA is given): InvalidArgument naming the flag, the path and OpenSSL's reason.
absl::StatusOr<std::shared_ptr<boost::asio::ssl::context>> BuildTlsContext(const TlsFiles& files);

/// The TLS context of new connections, built again when its files change (cert-manager
/// rotation).
class TlsContextSource {
  public:
    explicit TlsContextSource(TlsFiles files);

    /// Builds the first context: InvalidArgument as BuildTlsContext.
    absl::Status Load();
    /// The context for a new connection: rebuilt when a file changed (looked at no more than
    /// once a second); a rebuild that fails (a rotation half done) keeps the previous one and
    /// is logged once per change of the files.
    std::shared_ptr<boost::asio::ssl::context> Current();

  private:
    const TlsFiles files_;
    std::mutex mutex_;
    WatchedFiles watched_;
    std::shared_ptr<boost::asio::ssl::context> context_;
};

/// The subject of the certificate the peer of `ssl` presented (RFC 2253), "" without one.
std::string PeerCertificateSubject(ssl_st* ssl);

}  // namespace soilvol::server
