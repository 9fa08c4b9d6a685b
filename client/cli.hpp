#pragma once

namespace soilvol::client {

/// Parses the command line and runs the subcommand; returns the process exit code (ExitCode:
/// 0 ok, 1 failed RPC or not SERVING, 2 usage error or unreadable file; help exits 0).
int RunCli(int argc, const char* const* argv);

}  // namespace soilvol::client
