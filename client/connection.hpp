#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "grpc/health/v1/health.grpc.pb.h"
#include "soilvol/v1/soilvol.grpc.pb.h"

namespace soilvol::client {

/// Exit codes of every subcommand.
enum ExitCode : int {
    kExitOk = 0,
    kExitRpcError = 1,  ///< an RPC failed, or the health check is not SERVING
    kExitUsage = 2,     ///< bad arguments or unreadable input files
};

/// Options every subcommand takes, before or after its name.
struct GlobalOptions {
    std::string server = "localhost:50051";  ///< host:port; env SOILVOL_SERVER
    bool json = false;                       ///< proto3 JSON instead of tables
    double timeout_s = 120.0;                ///< deadline of each RPC [s]
    bool tls = false;                        ///< TLS with the system's roots (implied by tls_ca)
    std::string tls_ca;                      ///< PEM roots that signed the server's certificate
    std::string tls_client_cert;             ///< PEM chain for mTLS, with tls_client_key
    std::string tls_client_key;
    std::string tls_server_name;  ///< name checked in the certificate instead of the host's
    std::string token_file;       ///< a file holding the bearer token (env SOILVOL_TOKEN_FILE)
    std::string token;            ///< the bearer token itself (env SOILVOL_TOKEN)
};

/// The channel to the server (TLS and client certificates when asked for) with both stubs;
/// each call gets a fresh context carrying the bearer token.
class Connection {
  public:
    /// Reads the certificate and token files; a file that cannot be read is reported on stderr
    /// and leaves the connection unusable (ok() false).
    explicit Connection(const GlobalOptions& options);
    bool ok() const { return ok_; }

    v1::SoilVolume::Stub& Soil() { return *soil_; }
    grpc::health::v1::Health::Stub& Health() { return *health_; }

    /// A context whose deadline is timeout_s from now.
    std::unique_ptr<grpc::ClientContext> NewContext() const;
    /// A context without a deadline, for a watch that runs until stopped.
    std::unique_ptr<grpc::ClientContext> NewOpenContext() const;

  private:
    double timeout_s_;
    bool ok_ = true;
    std::string authorization_;  ///< "Bearer <token>", or empty
    std::shared_ptr<grpc::Channel> channel_;
    std::unique_ptr<v1::SoilVolume::Stub> soil_;
    std::unique_ptr<grpc::health::v1::Health::Stub> health_;
};

/// The canonical name of a gRPC status code ("NOT_FOUND"), CODE_<n> past the known ones; an int,
/// as it came off the wire (a value past grpc::StatusCode is no value of that enum).
std::string StatusCodeName(int code);

/// Prints `error: <CODE_NAME>: <message>` to stderr and returns kExitRpcError.
int ReportRpcError(const grpc::Status& status);

}  // namespace soilvol::client
