#include "client/cli.hpp"

#include <CLI/CLI.hpp>

#include "client/commands.hpp"

namespace soilvol::client {

int RunCli(int argc, const char* const* argv) {
    CLI::App app{"soilvol: volume of soil in a container, from soilvol-server"};
    app.require_subcommand(1);
    app.fallthrough();
    app.footer(
        "Global options --server, --json and --timeout-s go before or after the subcommand.");
    GlobalOptions global;
    app.add_option("--server", global.server, "server host:port")
        ->envname("SOILVOL_SERVER")
        ->capture_default_str();
    app.add_flag("--json", global.json, "print responses as proto3 JSON");
    app.add_option("--timeout-s", global.timeout_s, "deadline of each RPC [s]")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    int exit_code = kExitOk;
    AddCalibrateCommand(app, global, &exit_code);
    AddRegisterCommand(app, global, &exit_code);
    AddEstimateCommand(app, global, &exit_code);
    AddResourceCommands(app, global, &exit_code);
    AddHealthCommand(app, global, &exit_code);
    AddDemoCommand(app, global, &exit_code);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == static_cast<int>(CLI::ExitCodes::Success) ? kExitOk : kExitUsage;
    }
    return exit_code;
}

}  // namespace soilvol::client
