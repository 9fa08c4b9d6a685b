#include "server/http/http_routes.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/http/grpc_timeout.hpp"
#include "server/http/http_gateway.hpp"
#include "server/http/json_input.hpp"
#include "server/http/query_string.hpp"
#include "server/http/request_binding.hpp"
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
        "PATCH /v1/containers/{container.container_id} UpdateContainer",
        "GET /v1/containers/{container_id}/estimates ListEstimates",
        "GET /v1/containers/{container_id}/estimates/{estimate_id} GetEstimate",
        "GET /v1/estimates:watch WatchEstimates",
        "POST /v1/containers/{container_id}:estimate EstimateVolume",
        "GET /v1/info GetServerInfo",
        "POST /v1/loads CreateLoad",
        "GET /v1/loads/{load_id} GetLoad",
        "GET /v1/loads ListLoads",
        "POST /v1/loads/{load_id}:close CloseLoad",
        "GET /v1/loads:watch WatchLoads",
        "GET /v1/production GetProduction",
        "GET /v1/alerts ListAlerts",
        "GET /v1/alerts:watch WatchAlerts",
        "GET /v1/webhooks ListWebhooks",
        "GET /v1/webhooks/{webhook_id}/deliveries ListWebhookDeliveries",
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

const HttpRoute& RouteOf(const std::vector<HttpRoute>& routes, const std::string& method) {
    for (const HttpRoute& route : routes) {
        if (route.method == method) return route;
    }
    throw std::runtime_error("no route for " + method);
}

class BindRequestTest : public ::testing::Test {
  protected:
    absl::Status Bind(const std::string& method, const std::string& query,
                      const std::string& content_type, std::string body,
                      google::protobuf::Message* message,
                      std::map<std::string, std::string> path = {}) {
        return BindRequest(RouteOf(routes_, method), path, query, content_type, body, message);
    }
    std::vector<HttpRoute> routes_ = *RoutesFromAnnotations(Api());
};

TEST_F(BindRequestTest, JsonBodiesIgnoreUnknownFieldsAndRefuseQueryParameters) {
    v1::RegisterContainerRequest request;
    ASSERT_TRUE(Bind("RegisterContainer", "", "application/json",
                     R"({"containerId": "a", "fromANewerClient": {"x": 1}})", &request)
                    .ok());
    EXPECT_EQ(request.container_id(), "a");
    const absl::Status status =
        Bind("RegisterContainer", "overwrite=true", "application/json", "{}", &request);
    EXPECT_TRUE(absl::IsInvalidArgument(status));
}

// A client reads the message: plain text naming the body and where it broke, no escapes of
// the parser's own (protobuf quotes the input with \x0a for its newlines).
TEST_F(BindRequestTest, MalformedJsonIsReadableText) {
    v1::RegisterContainerRequest request;
    const absl::Status status = Bind("RegisterContainer", "", "application/json",
                                     "{\"containerId\": \n \"a\",\n,}", &request);
    ASSERT_TRUE(absl::IsInvalidArgument(status));
    const std::string message(status.message());
    EXPECT_EQ(message.rfind("request body: ", 0), 0u) << message;
    EXPECT_EQ(message.find("\\x"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_EQ(message, "request body: Expected an object key or } at line 3, column 1 (byte 23)");
}

TEST_F(BindRequestTest, PatchBodyIsTheResourceAndItsFieldsTheMask) {
    const std::vector<HttpRoute>& routes = routes_;
    const absl::StatusOr<RouteMatch> match =
        MatchRoute(routes, "PATCH", "/v1/containers/truck%2D7");
    ASSERT_TRUE(match.ok()) << match.status();
    v1::UpdateContainerRequest request;
    std::string body =
        R"({"displayName": "T7", "material": {"densityKgM3": 1800, "name": "clay"},
            "labels": {"a": "b"}, "loadTargets": null, "unknownField": 1})";
    ASSERT_TRUE(
        BindRequest(*match->route, match->fields, "", "application/json", body, &request).ok());
    EXPECT_EQ(request.container().container_id(), "truck-7");
    EXPECT_EQ(request.container().display_name(), "T7");
    EXPECT_EQ(request.container().material().density_kg_m3(), 1800.0);
    const std::set<std::string> paths(request.update_mask().paths().begin(),
                                      request.update_mask().paths().end());
    EXPECT_EQ(paths, (std::set<std::string>{"display_name", "material.density_kg_m3",
                                            "material.name", "labels", "load_targets"}));
    // A mask in the query replaces the derived one, bare or quoted.
    v1::UpdateContainerRequest masked;
    body = R"({"displayName": "T7"})";
    ASSERT_TRUE(BindRequest(*match->route, match->fields, "updateMask=displayName,labels",
                            "application/json", body, &masked)
                    .ok());
    EXPECT_EQ(masked.update_mask().paths_size(), 2);
    EXPECT_EQ(masked.update_mask().paths(1), "labels");
}

TEST_F(BindRequestTest, BinaryBodyIsTheCloudAndTheQueryTheRest) {
    v1::EstimateVolumeRequest request;
    const std::string ply = std::string("ply\0binary", 10);
    std::string body = ply;
    const absl::Status status = BindRequest(
        RouteOf(routes_, "EstimateVolume"), {{"container_id", "b7"}},
        "gridCellM=0.05&method=ESTIMATION_METHOD_PAPER&container_pose.pose.position_m.x=1.5&"
        "containerPose.positionSigmaM=0.1&requestId=r%201",
        "application/octet-stream", body, &request);
    ASSERT_TRUE(status.ok()) << status;
    EXPECT_EQ(request.scan().cloud().data(), ply);
    EXPECT_TRUE(body.empty());  // moved, not copied
    EXPECT_EQ(request.container_id(), "b7");
    EXPECT_DOUBLE_EQ(request.grid_cell_m(), 0.05);
    EXPECT_EQ(request.method(), v1::ESTIMATION_METHOD_PAPER);
    EXPECT_DOUBLE_EQ(request.container_pose().pose().position_m().x(), 1.5);
    EXPECT_DOUBLE_EQ(request.container_pose().position_sigma_m(), 0.1);
    EXPECT_EQ(request.request_id(), "r 1");
}

TEST_F(BindRequestTest, QueryMessagesTakeJsonAndEnumsTakeNumbers) {
    v1::RegisterContainerRequest request;
    const absl::Status status =
        Bind("RegisterContainer",
             "opening=%7B%22corners%22%3A%5B%7B%22x%22%3A1%7D%5D%7D&containerId=c&overwrite=true",
             "application/octet-stream", "ply", &request);
    ASSERT_TRUE(status.ok()) << status;
    ASSERT_EQ(request.opening().corners_size(), 1);
    EXPECT_DOUBLE_EQ(request.opening().corners(0).x(), 1.0);
    EXPECT_TRUE(request.overwrite());
    v1::EstimateVolumeRequest estimate;
    ASSERT_TRUE(
        Bind("EstimateVolume", "method=2", "application/octet-stream", "ply", &estimate).ok());
    EXPECT_EQ(estimate.method(), v1::ESTIMATION_METHOD_PAPER);
}

TEST_F(BindRequestTest, BadParametersNameThemselves) {
    const std::pair<std::string, std::string> cases[] = {
        {"gridCel=1", "unknown parameter 'gridCel'"},
        {"grid_cell_m=abc", "grid_cell_m: 'abc' is not a valid value"},
        {"method=NOPE", "method: 'NOPE' is not a valid value"},
        {"scan.cloud.data=abc", "scan.cloud.data: bytes cannot be set"},
        {"container_pose.pose.nope=1", "unknown parameter"},
        {"grid_cell_m.x=1", "unknown parameter"},
        {"opening=%7Bnot%20json", "opening: "},
        {"overwrite=yes", "overwrite: 'yes' is not a valid value"},
    };
    for (const auto& [query, message] : cases) {
        v1::EstimateVolumeRequest request;
        v1::RegisterContainerRequest register_request;
        const bool registering = query.rfind("opening", 0) == 0 || query.rfind("overwrite", 0) == 0;
        const absl::Status status =
            registering
                ? Bind("RegisterContainer", query, "application/octet-stream", "ply",
                       &register_request)
                : Bind("EstimateVolume", query, "application/octet-stream", "ply", &request);
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << query;
        EXPECT_NE(status.message().find(message), std::string::npos) << status << " for " << query;
    }
}

TEST_F(BindRequestTest, MultipartFillsTheScanFromFileParts) {
    const std::string body =
        "--B\r\nContent-Disposition: form-data; name=\"request\"\r\n\r\n"
        "{\"containerId\": \"s1\", \"overwrite\": true}\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"max_range_m\"\r\n\r\n12.5\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"left\"; filename=\"l.png\"\r\n\r\nLEFT\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"right\"; filename=\"r.png\"\r\n\r\nRIGHT\r\n"
        "--B--\r\n";
    v1::RegisterContainerRequest request;
    const absl::Status status =
        Bind("RegisterContainer", "", "multipart/form-data; boundary=B", body, &request);
    ASSERT_TRUE(status.ok()) << status;
    EXPECT_EQ(request.container_id(), "s1");
    EXPECT_TRUE(request.overwrite());
    EXPECT_DOUBLE_EQ(request.max_range_m(), 12.5);
    EXPECT_EQ(request.scan().stereo().left(), "LEFT");
    EXPECT_EQ(request.scan().stereo().right(), "RIGHT");
}

TEST_F(BindRequestTest, RoutesWithoutAScanTakeNoFiles) {
    v1::CalibrateRequest request;
    EXPECT_TRUE(absl::IsInvalidArgument(
        Bind("Calibrate", "", "application/octet-stream", "ply", &request)));
    const std::string body =
        "--B\r\nContent-Disposition: form-data; name=\"cloud\"\r\n\r\nply\r\n--B--\r\n";
    const absl::Status status =
        Bind("Calibrate", "", "multipart/form-data; boundary=B", body, &request);
    EXPECT_NE(status.message().find("takes no scan"), std::string::npos) << status;
    EXPECT_TRUE(
        absl::IsInvalidArgument(Bind("RegisterContainer", "", "text/plain", "x", &request)));
}

TEST_F(BindRequestTest, BinaryBodyIsTheMeshWhenTheQuerySaysSo) {
    v1::RegisterContainerRequest request;
    std::string body = std::string("solid\0stl", 9);
    const std::string stl = body;
    // A message given as JSON in the query does not clear the file, bound after it.
    const absl::Status status =
        Bind("RegisterContainer",
             "file=mesh&containerId=m1&mesh=%7B%22rangeNoiseM%22%3A0.01%7D&"
             "mesh.corners=%7B%22x%22%3A1%7D&mesh.containerPose.positionM.z=-2",
             "application/octet-stream", body, &request);
    ASSERT_TRUE(status.ok()) << status;
    EXPECT_EQ(request.mesh().data(), stl);
    EXPECT_FALSE(request.has_scan());
    EXPECT_EQ(request.container_id(), "m1");
    EXPECT_DOUBLE_EQ(request.mesh().range_noise_m(), 0.01);
    ASSERT_EQ(request.mesh().corners_size(), 1);
    EXPECT_DOUBLE_EQ(request.mesh().container_pose().position_m().z(), -2.0);
    v1::RegisterContainerRequest cloud;
    ASSERT_TRUE(
        Bind("RegisterContainer", "file=cloud", "application/octet-stream", "ply", &cloud).ok());
    EXPECT_EQ(cloud.scan().cloud().data(), "ply");
    EXPECT_FALSE(cloud.has_mesh());
}

TEST_F(BindRequestTest, BinaryBodyFilesOutsideTheRouteNameTheParameter) {
    const std::pair<std::string, std::string> cases[] = {
        {"file=left", "file: 'left' is not cloud, depth or mesh"},
        {"file=nope", "file: 'nope' is not cloud, depth or mesh"},
        {"file=mesh&file=mesh", "file: is given twice"},
        {"file=mesh&mesh.data=abc", "mesh.data: bytes cannot be set"},
        {"file=mesh&mesh=%7B%22data%22%3A%22c3Rs%22%7D", "mesh.data: given twice"},
    };
    for (const auto& [query, message] : cases) {
        v1::RegisterContainerRequest request;
        const absl::Status status =
            Bind("RegisterContainer", query, "application/octet-stream", "stl", &request);
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << query;
        EXPECT_NE(status.message().find(message), std::string::npos) << status << " for " << query;
    }
    v1::EstimateVolumeRequest estimate;
    const absl::Status status =
        Bind("EstimateVolume", "file=mesh", "application/octet-stream", "stl", &estimate);
    EXPECT_EQ(status.message(), "file: this route takes no mesh") << status;
    // On JSON and multipart bodies `file` is no parameter.
    v1::RegisterContainerRequest json;
    EXPECT_TRUE(absl::IsInvalidArgument(
        Bind("RegisterContainer", "file=mesh", "application/json", "{}", &json)));
}

TEST_F(BindRequestTest, MultipartMeshPartFillsTheMeshBesideTheCloud) {
    const std::string body =
        "--B\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"b.stl\"\r\n\r\nSTL\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"mesh.rangeNoiseM\"\r\n\r\n0.02\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"cloud\"; filename=\"e.ply\"\r\n\r\nPLY\r\n"
        "--B\r\nContent-Disposition: form-data; name=\"request\"\r\n\r\n"
        "{\"containerId\": \"s2\", \"mesh\": {\"corners\": [{\"x\": 1}, {\"y\": 2}]}}\r\n"
        "--B--\r\n";
    v1::RegisterContainerRequest request;
    const absl::Status status =
        Bind("RegisterContainer", "", "multipart/form-data; boundary=B", body, &request);
    ASSERT_TRUE(status.ok()) << status;
    EXPECT_EQ(request.mesh().data(), "STL");
    EXPECT_EQ(request.mesh().corners_size(), 2);
    EXPECT_DOUBLE_EQ(request.mesh().range_noise_m(), 0.02);
    EXPECT_EQ(request.scan().cloud().data(), "PLY");
    const std::string estimate_body =
        "--B\r\nContent-Disposition: form-data; name=\"mesh\"\r\n\r\nSTL\r\n--B--\r\n";
    v1::EstimateVolumeRequest estimate;
    const absl::Status refused =
        Bind("EstimateVolume", "", "multipart/form-data; boundary=B", estimate_body, &estimate);
    EXPECT_NE(refused.message().find("part 'mesh': this route takes no mesh"), std::string::npos)
        << refused;
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
