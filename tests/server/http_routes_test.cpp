#include "server/http_routes.hpp"

#include <gtest/gtest.h>

#include <set>

#include "server/http_gateway.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {
namespace {

const google::protobuf::ServiceDescriptor& Api() {
    return *v1::CalibrateRequest::descriptor()->file()->FindServiceByName("SoilVolume");
}

// The REST contract that dashboards depend on, as the issue states it.
TEST(HttpRoutes, AnnotationsGiveTheDocumentedContract) {
    const absl::StatusOr<std::vector<HttpRoute>> routes = RoutesFromAnnotations(Api());
    ASSERT_TRUE(routes.ok()) << routes.status();
    std::set<std::string> got;
    for (const HttpRoute& route : *routes)
        got.insert(route.verb + " " + route.pattern + " " + route.method);
    const std::set<std::string> expected = {
        "POST /v1/calibrations Calibrate",
        "GET /v1/calibrations/{calibration_id} GetCalibration",
        "GET /v1/calibrations ListCalibrations",
        "DELETE /v1/calibrations/{calibration_id} DeleteCalibration",
        "POST /v1/containers RegisterContainer",
        "GET /v1/containers/{container_id} GetContainer",
        "GET /v1/containers ListContainers",
        "DELETE /v1/containers/{container_id} DeleteContainer",
        "POST /v1/containers/{container_id}:estimate EstimateVolume",
        "GET /v1/info GetServerInfo",
    };
    EXPECT_EQ(got, expected);
}

TEST(HttpRoutes, EveryUnaryRpcHasARoute) {
    const absl::StatusOr<std::vector<HttpRoute>> routes = RoutesFromAnnotations(Api());
    ASSERT_TRUE(routes.ok());
    std::set<std::string> routed;
    for (const HttpRoute& route : *routes) routed.insert(route.method);
    for (int i = 0; i < Api().method_count(); ++i) {
        const auto* method = Api().method(i);
        if (method->client_streaming() || method->server_streaming()) continue;
        EXPECT_TRUE(routed.count(method->name())) << method->name();
    }
}

TEST(HttpRoutes, MatchesPathsAndDecodesValues) {
    const std::vector<HttpRoute> routes = *RoutesFromAnnotations(Api());
    absl::StatusOr<RouteMatch> m = MatchRoute(routes, "POST", "/v1/containers/bucket-7.a:estimate");
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_EQ(m->route->method, "EstimateVolume");
    EXPECT_EQ(m->fields.at("container_id"), "bucket-7.a");
    m = MatchRoute(routes, "GET", "/v1/containers/bucket%207");
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(m->fields.at("container_id"), "bucket 7");
    m = MatchRoute(routes, "GET", "/v1/containers");
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(m->route->method, "ListContainers");
}

TEST(HttpRoutes, UnknownPathsVerbsAndBadEncodingAreRefused) {
    const std::vector<HttpRoute> routes = *RoutesFromAnnotations(Api());
    EXPECT_TRUE(absl::IsNotFound(MatchRoute(routes, "GET", "/v1/nothing").status()));
    EXPECT_TRUE(absl::IsNotFound(MatchRoute(routes, "GET", "/v1/containers/a/b").status()));
    EXPECT_TRUE(absl::IsNotFound(MatchRoute(routes, "GET", "/v1/containers/").status()));
    EXPECT_TRUE(absl::IsUnimplemented(MatchRoute(routes, "PUT", "/v1/containers").status()));
    EXPECT_TRUE(
        absl::IsUnimplemented(MatchRoute(routes, "GET", "/v1/containers/a:estimate").status()));
    EXPECT_TRUE(absl::IsInvalidArgument(MatchRoute(routes, "GET", "/v1/containers/a%2").status()));
    EXPECT_TRUE(absl::IsInvalidArgument(MatchRoute(routes, "GET", "/v1/containers/a%zz").status()));
}

TEST(GrpcTimeout, ParsesEveryUnitAndRefusesJunk) {
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("10S"), 10000.0);
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("500m"), 500.0);
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("2M"), 120000.0);
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("1H"), 3600000.0);
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("250u"), 0.25);
    EXPECT_DOUBLE_EQ(*ParseGrpcTimeout("100n"), 1e-4);
    for (const char* bad : {"", "S", "10", "10s", "-1S", "1.5S", "123456789S", "1 S", "0x1S"}) {
        EXPECT_FALSE(ParseGrpcTimeout(bad).ok()) << bad;
    }
}

}  // namespace
}  // namespace soilvol::server
