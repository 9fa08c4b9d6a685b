#include "client/cli.hpp"

#include <CLI/CLI.hpp>

#include "client/commands.hpp"
#include "core/common/build_info.hpp"

namespace soilvol::client {

int RunCli(int argc, const char* const* argv) {
    CLI::App app{"soilvol: volume of soil in a container, from soilvol-server"};
    app.set_version_flag("--version", VersionLine("soilvol"));
    app.require_subcommand(1);
    app.fallthrough();
    app.footer(
        "Global options (--server, --json, --timeout-s, --tls*, --token*) go before or after the "
        "subcommand.");
    GlobalOptions global;
    app.add_option("--server", global.server, "server host:port")
        ->envname("SOILVOL_SERVER")
        ->capture_default_str();
    app.add_flag("--json", global.json, "print responses as proto3 JSON");
    app.add_option("--timeout-s", global.timeout_s, "deadline of each RPC [s]")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    app.add_flag("--tls", global.tls, "TLS, with the system's root certificates")
        ->envname("SOILVOL_TLS");
    app.add_option("--tls-ca", global.tls_ca, "TLS, with this PEM root (the server's CA)")
        ->envname("SOILVOL_TLS_CA");
    app.add_option("--tls-client-cert", global.tls_client_cert,
                   "PEM client certificate chain (mTLS)")
        ->envname("SOILVOL_TLS_CLIENT_CERT");
    app.add_option("--tls-client-key", global.tls_client_key, "PEM key of --tls-client-cert")
        ->envname("SOILVOL_TLS_CLIENT_KEY");
    app.add_option("--tls-server-name", global.tls_server_name,
                   "name to check in the server's certificate (default: the --server host)")
        ->envname("SOILVOL_TLS_SERVER_NAME");
    app.add_option("--token-file", global.token_file, "file holding the bearer token")
        ->envname("SOILVOL_TOKEN_FILE");
    app.add_option("--token", global.token,
                   "bearer token (prefer SOILVOL_TOKEN or --token-file: arguments are visible "
                   "to other users)")
        ->envname("SOILVOL_TOKEN");
    int exit_code = kExitOk;
    AddCalibrateCommand(app, global, &exit_code);
    AddRegisterCommand(app, global, &exit_code);
    AddEstimateCommand(app, global, &exit_code);
    AddResourceCommands(app, global, &exit_code);
    AddEstimatesCommand(app, global, &exit_code);
    AddLoadsCommand(app, global, &exit_code);
    AddAlertsCommands(app, global, &exit_code);
    AddHealthCommand(app, global, &exit_code);
    AddDemoCommand(app, global, &exit_code);
    AddShiftDemoCommand(app, global, &exit_code);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == static_cast<int>(CLI::ExitCodes::Success) ? kExitOk : kExitUsage;
    }
    return exit_code;
}

}  // namespace soilvol::client
