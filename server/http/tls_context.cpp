#include "server/http/tls_context.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <boost/asio/ssl.hpp>

#include "absl/strings/str_cat.h"
#include "server/base/logging.hpp"

namespace soilvol::server {
namespace {

namespace ssl = boost::asio::ssl;

// "--tls-cert /etc/tls.crt: no start line" from the error OpenSSL reported.
absl::Status TlsFileError(const char* flag, const std::string& path,
                          const boost::system::system_error& e) {
    const char* reason = ERR_reason_error_string(static_cast<unsigned long>(e.code().value()));
    return absl::InvalidArgumentError(absl::StrCat(
        flag, " ", path, ": ", reason != nullptr ? reason : e.code().message().c_str()));
}

}  // namespace

absl::StatusOr<std::shared_ptr<ssl::context>> BuildTlsContext(const TlsFiles& files) {
    auto context = std::make_shared<ssl::context>(ssl::context::tls_server);
    context->set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 |
                         ssl::context::no_sslv3 | ssl::context::no_tlsv1 |
                         ssl::context::no_tlsv1_1 | ssl::context::single_dh_use);
    try {
        context->use_certificate_chain_file(files.cert_path);
    } catch (const boost::system::system_error& e) {
        return TlsFileError("--tls-cert", files.cert_path, e);
    }
    try {
        context->use_private_key_file(files.key_path, ssl::context::pem);
    } catch (const boost::system::system_error& e) {
        return TlsFileError("--tls-key", files.key_path, e);
    }
    if (SSL_CTX_check_private_key(context->native_handle()) != 1) {
        return absl::InvalidArgumentError(absl::StrCat(
            "--tls-key ", files.key_path, ": does not match the certificate in ", files.cert_path));
    }
    if (!files.client_ca_path.empty()) {
        try {
            context->load_verify_file(files.client_ca_path);
        } catch (const boost::system::system_error& e) {
            return TlsFileError("--tls-client-ca", files.client_ca_path, e);
        }
        context->set_verify_mode(ssl::verify_peer | ssl::verify_fail_if_no_peer_cert);
    }
    return context;
}

TlsContextSource::TlsContextSource(TlsFiles files)
    : files_(std::move(files)),
      watched_({files_.cert_path, files_.key_path, files_.client_ca_path}) {}

absl::Status TlsContextSource::Load() {
    watched_.Mark();
    absl::StatusOr<std::shared_ptr<ssl::context>> context = BuildTlsContext(files_);
    if (!context.ok()) return context.status();
    context_ = *std::move(context);
    return absl::OkStatus();
}

std::shared_ptr<ssl::context> TlsContextSource::Current() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (watched_.Changed()) {
        watched_.Mark();
        absl::StatusOr<std::shared_ptr<ssl::context>> context = BuildTlsContext(files_);
        if (context.ok()) {
            context_ = *std::move(context);
            LogEvent(LogLevel::kInfo, "tls files reloaded", {});
        } else {
            LogEvent(LogLevel::kError, "tls files not reloaded",
                     {{"error", context.status().message()}});
        }
    }
    return context_;
}

std::string PeerCertificateSubject(ssl_st* ssl) {
    X509* cert = SSL_get_peer_certificate(ssl);
    if (cert == nullptr) return "";
    std::string subject;
    BIO* bio = BIO_new(BIO_s_mem());
    if (bio != nullptr &&
        X509_NAME_print_ex(bio, X509_get_subject_name(cert), 0, XN_FLAG_RFC2253) >= 0) {
        char* data = nullptr;
        const long size = BIO_get_mem_data(bio, &data);
        if (size > 0) subject.assign(data, static_cast<std::size_t>(size));
    }
    BIO_free(bio);
    X509_free(cert);
    return subject;
}

absl::Status CheckTlsFiles(const TlsFiles& files) {
    ERR_clear_error();
    return BuildTlsContext(files).status();
}

}  // namespace soilvol::server
