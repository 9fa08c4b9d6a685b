#include "client/cli.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "client/connection.hpp"

namespace soilvol::client {
namespace {

// A port nothing listens on: connections are refused at once.
constexpr const char* kDeadServer = "127.0.0.1:1";

int RunSoilvol(std::vector<const char*> args) {
    args.insert(args.begin(), "soilvol");
    return RunCli(static_cast<int>(args.size()), args.data());
}

TEST(Cli, HelpExitsZero) {
    testing::internal::CaptureStdout();
    EXPECT_EQ(RunSoilvol({"--help"}), kExitOk);
    EXPECT_NE(testing::internal::GetCapturedStdout().find("demo"), std::string::npos);
}

TEST(Cli, UsageErrorsExitTwo) {
    const std::vector<std::vector<const char*>> cases = {
        {},
        {"nosuchcommand"},
        {"estimate", "--cloud", "scan.ply"},
        {"estimate", "--id", "x", "--cloud", "a.ply", "--left", "l.png"},
        {"estimate", "--id", "x", "--method", "magic", "--cloud", "a.ply"},
        {"register", "--id", "x", "--cloud", "a.ply"},
        {"calibrate", "--parameters", "p.json", "--cols", "9"},
        {"containers"},
        {"containers", "get"},
        {"demo", "--fills", "0,3"},
        {"demo", "--container", "barrel"},
        {"health", "--timeout-s", "-1"},
        {"estimate", "--id", "x", "--depth", "d.png"},
        {"estimate", "--id", "x", "--depth", "d.png", "--intrinsics", "1,2,3"},
        {"estimate", "--id", "x", "--depth", "d.png", "--intrinsics", "1,2,3,4", "--cloud",
         "a.ply"},
        {"estimate", "--id", "x", "--depth", "d.png", "--intrinsics", "1,2,3,4", "--lens", "fish"},
        {"estimate", "--id", "x", "--cloud", "a.ply", "--confidence", "c.png"},
        {"register", "--id", "x", "--intrinsics", "1,2,3,4", "--cloud", "a.ply"},
        {"estimate", "--id", "x", "--depth", "d.png", "--intrinsics", "1,2,3,4", "--sensor-pose",
         "0,0,5,1,0,0,0"},
        {"estimate", "--id", "x", "--cloud", "a.ply", "--sensor-pose", "0,0,5,1,0,0"},
    };
    for (const auto& args : cases) {
        testing::internal::CaptureStderr();
        EXPECT_EQ(RunSoilvol(args), kExitUsage) << (args.empty() ? "(none)" : args[0]);
        testing::internal::GetCapturedStderr();
    }
}

TEST(Cli, UnreadableFileNamesItAndExitsTwoBeforeAnyRpc) {
    testing::internal::CaptureStderr();
    EXPECT_EQ(RunSoilvol({"estimate", "--id", "x", "--cloud", "/nonexistent/scan.ply", "--json",
                          "--server", kDeadServer}),
              kExitUsage);
    EXPECT_EQ(testing::internal::GetCapturedStderr(),
              "error: cannot read '/nonexistent/scan.ply': No such file or directory\n");
}

TEST(Cli, MalformedCornersExitTwo) {
    testing::internal::CaptureStderr();
    EXPECT_EQ(RunSoilvol({"register", "--id", "x", "--cloud", "/dev/null", "--corners",
                          "1,2,3;4,5,6", "--server", kDeadServer}),
              kExitUsage);
    EXPECT_NE(testing::internal::GetCapturedStderr().find("--corners needs 4 points"),
              std::string::npos);
}

TEST(Cli, MeshRegistrationsNeedTheirPlacementOrAScan) {
    const std::string corners = "0,0,0;1,0,0;1,1,0;0,1,0";
    const std::pair<std::vector<const char*>, const char*> cases[] = {
        {{"register", "--id", "x", "--mesh", "/dev/null"}, "--mesh-corners"},
        {{"register", "--id", "x", "--mesh-corners", corners.c_str()}, "--mesh"},
        {{"register", "--id", "x", "--mesh", "/dev/null", "--mesh-corners", corners.c_str()},
         "--container-pose and --range-noise"},
        {{"register", "--id", "x", "--mesh", "/dev/null", "--mesh-corners", corners.c_str(),
          "--container-pose", "0,0,-3", "--range-noise", "0.01", "--cloud", "/dev/null",
          "--corners", corners.c_str()},
         "for a mesh without a scan"},
        {{"register", "--id", "x", "--mesh", "/dev/null", "--mesh-corners", corners.c_str(),
          "--container-pose", "0,0,-3;2,0,0,0", "--range-noise", "0.01"},
         "norm 1"},
        {{"register", "--id", "x", "--mesh", "/dev/null", "--mesh-corners", corners.c_str(),
          "--container-pose", "0,0,-3", "--range-noise", "0.01", "--corners", corners.c_str()},
         "--mesh-corners"},
        {{"register", "--id", "x", "--cloud", "/dev/null", "--mesh", "/dev/null", "--mesh-corners",
          corners.c_str()},
         "--corners"},
        {{"register", "--id", "x", "--mesh", "/nonexistent/box.stl", "--mesh-corners",
          corners.c_str(), "--container-pose", "0,0,-3", "--range-noise", "0.01"},
         "cannot read '/nonexistent/box.stl'"},
    };
    for (const auto& [args, fragment] : cases) {
        std::vector<const char*> with_server = args;
        with_server.insert(with_server.end(), {"--server", kDeadServer});
        testing::internal::CaptureStderr();
        EXPECT_EQ(RunSoilvol(with_server), kExitUsage) << fragment;
        const std::string err = testing::internal::GetCapturedStderr();
        EXPECT_NE(err.find(fragment), std::string::npos) << err;
    }
}

TEST(Cli, FailedRpcPrintsCodeNameAndExitsOne) {
    for (const auto& args : std::vector<std::vector<const char*>>{
             {"containers", "list", "--server", kDeadServer},
             {"--server", kDeadServer, "--json", "calibrations", "get", "rig"},
             {"health", "--timeout-s", "5", "--server", kDeadServer}}) {
        testing::internal::CaptureStderr();
        EXPECT_EQ(RunSoilvol(args), kExitRpcError);
        EXPECT_EQ(testing::internal::GetCapturedStderr().rfind("error: UNAVAILABLE: ", 0), 0u);
    }
}

TEST(Cli, StatusCodeNamesAreCanonical) {
    EXPECT_EQ(StatusCodeName(grpc::StatusCode::NOT_FOUND), "NOT_FOUND");
    EXPECT_EQ(StatusCodeName(grpc::StatusCode::FAILED_PRECONDITION), "FAILED_PRECONDITION");
    EXPECT_EQ(StatusCodeName(grpc::StatusCode::UNAUTHENTICATED), "UNAUTHENTICATED");
    EXPECT_EQ(StatusCodeName(42), "CODE_42");
}

}  // namespace
}  // namespace soilvol::client
