#pragma once

#include <CLI/CLI.hpp>

#include "client/connection.hpp"

namespace soilvol::client {

/// Each adds its subcommand(s) to `app`; the subcommand's callback runs it against the server
/// named in `global` (read when it runs) and stores its exit code in `*exit_code`.
void AddCalibrateCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddRegisterCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddEstimateCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddEstimatesCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddLoadsCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddAlertsCommands(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddResourceCommands(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddHealthCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddDemoCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);
void AddShiftDemoCommand(CLI::App& app, const GlobalOptions& global, int* exit_code);

}  // namespace soilvol::client
