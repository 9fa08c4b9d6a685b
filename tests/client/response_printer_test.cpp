#include "client/response_printer.hpp"

#include <gtest/gtest.h>

#include <sstream>

namespace soilvol::client {
namespace {

v1::Container WarnedContainer() {
    v1::Container c;
    c.set_container_id("bin-3");
    c.set_registered_from(v1::SCAN_KIND_CLOUD);
    c.set_struck_capacity_m3(0.6638);
    c.set_struck_capacity_uncertainty_m3(0.0171);
    v1::UnseenSide* side = c.add_unseen_sides();
    side->set_from_corner(0);
    side->set_to_corner(1);
    side->set_area_m2(0.2048);
    side->set_uncertainty_m3(0.0161);
    c.add_warnings("the struck capacity's 1-sigma is 17.1 L");
    return c;
}

TEST(PrintContainer, ShowsTheCapacitysSigmaUnseenSidesAndEveryWarning) {
    std::ostringstream out;
    v1::Container c = WarnedContainer();
    c.add_warnings("second");
    PrintContainer(c, false, out);
    const std::string text = out.str();
    EXPECT_NE(text.find("struck 1-sigma [L]     17.1"), std::string::npos) << text;
    EXPECT_NE(text.find("corners 1-2: 0.20 m^2, 16.1 L"), std::string::npos) << text;
    EXPECT_NE(text.find("\nwarning: the struck capacity's 1-sigma is 17.1 L\n"), std::string::npos)
        << text;
    EXPECT_NE(text.find("\nwarning: second\n"), std::string::npos) << text;
}

TEST(PrintContainer, MeshRegistrationsSayTheirSource) {
    v1::Container alone;
    alone.set_registered_from(v1::SCAN_KIND_MESH);
    alone.set_has_mesh(true);
    std::ostringstream out;
    PrintContainer(alone, false, out);
    EXPECT_NE(out.str().find("registered from        mesh\n"), std::string::npos) << out.str();
    EXPECT_NE(out.str().find("unseen sides           none"), std::string::npos) << out.str();
    EXPECT_EQ(out.str().find("warning:"), std::string::npos) << out.str();
    v1::Container both = alone;
    both.set_registered_from(v1::SCAN_KIND_CLOUD);
    out.str("");
    PrintContainer(both, false, out);
    EXPECT_NE(out.str().find("registered from        cloud + mesh"), std::string::npos)
        << out.str();
}

TEST(PrintEstimate, NamesTheRecordKeptOrSaysThereIsNone) {
    v1::EstimateVolumeResponse e;
    e.set_container_id("bin-3");
    e.set_estimate_id("000000000042");
    std::ostringstream out;
    PrintEstimate(e, false, out);
    EXPECT_NE(out.str().find("\nestimate id "), std::string::npos) << out.str();
    EXPECT_NE(out.str().find(" 000000000042\n"), std::string::npos) << out.str();
    e.clear_estimate_id();
    out.str("");
    PrintEstimate(e, false, out);
    EXPECT_NE(out.str().find(" none (not recorded)\n"), std::string::npos) << out.str();
}

TEST(PrintContainerList, HasASigmaColumnAndTheWarningsByContainer) {
    v1::ListContainersResponse list;
    *list.add_containers() = WarnedContainer();
    list.add_containers()->set_container_id("quiet");
    std::ostringstream out;
    PrintContainerList(list, false, out);
    const std::string text = out.str();
    EXPECT_NE(text.find("1-sigma [L]"), std::string::npos) << text;
    EXPECT_NE(text.find("warning: bin-3: the struck capacity's 1-sigma is 17.1 L\n"),
              std::string::npos)
        << text;
    EXPECT_EQ(text.find("warning: quiet"), std::string::npos) << text;
}

}  // namespace
}  // namespace soilvol::client
