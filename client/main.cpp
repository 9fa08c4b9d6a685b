// soilvol: command-line client of soilvol-server (gRPC). `soilvol --help` lists the subcommands.
#include "client/cli.hpp"

int main(int argc, char** argv) { return soilvol::client::RunCli(argc, argv); }
