#include "client/demo_table.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <sstream>

namespace soilvol::client {
namespace {

std::vector<DemoRow> Rows() {
    DemoRow ok{0.5, 0.330, 0.660, v1::EstimateVolumeResponse(), "", 20.0};
    ok.estimate->set_volume_m3(0.3366);
    ok.estimate->set_uncertainty_m3(0.004);
    ok.estimate->mutable_timings()->set_total_ms(15.5);
    DemoRow failed{1.0, 0.660, 0.660, std::nullopt, "INTERNAL: \"quoted\"\n", 3.0};
    return {ok, failed};
}

TEST(PrintDemoRows, JsonIsAnArrayOfRowsWithErrorsInPlace) {
    std::ostringstream out;
    PrintDemoRows(Rows(), true, out);
    google::protobuf::ListValue list;
    ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(out.str(), &list).ok()) << out.str();
    ASSERT_EQ(list.values_size(), 2);
    const auto& ok = list.values(0).struct_value().fields();
    EXPECT_DOUBLE_EQ(ok.at("fill").number_value(), 0.5);
    EXPECT_NEAR(ok.at("trueL").number_value(), 330.0, 1e-3);
    EXPECT_NEAR(ok.at("errorL").number_value(), 6.6, 1e-3);
    EXPECT_NEAR(ok.at("errorPctStruck").number_value(), 1.0, 1e-3);
    EXPECT_NEAR(ok.at("uncertaintyL").number_value(), 4.0, 1e-3);
    EXPECT_NEAR(ok.at("serverMs").number_value(), 15.5, 1e-3);
    const auto& failed = list.values(1).struct_value().fields();
    EXPECT_EQ(failed.at("error").string_value(), "INTERNAL: \"quoted\"\n");
    EXPECT_EQ(failed.count("measuredL"), 0u);
}

TEST(PrintDemoRows, TableHasUnitsAndDashesForFailures) {
    std::ostringstream out;
    PrintDemoRows(Rows(), false, out);
    const std::string text = out.str();
    EXPECT_NE(text.find("true [L]"), std::string::npos);
    EXPECT_NE(text.find("error [% struck]"), std::string::npos);
    EXPECT_NE(text.find("+6.6"), std::string::npos);
    EXPECT_NE(text.find("+1.00"), std::string::npos);
    EXPECT_NE(text.find("  -  "), std::string::npos);
}

}  // namespace
}  // namespace soilvol::client
