#include "server/rpc_table.hpp"

#include <gtest/gtest.h>

#include <memory>

#include "server/store/entry_store.hpp"
#include "soilvol/v1/soilvol.pb.h"
#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

const google::protobuf::ServiceDescriptor& Api() {
    return *v1::EstimateVolumeRequest::descriptor()->file()->FindServiceByName("SoilVolume");
}

class RpcTableTest : public ::testing::Test {
  protected:
    void SetUp() override {
        auto opened = EntryStore::Open(dir_.path());
        ASSERT_TRUE(opened.ok()) << opened.status();
        store_ = *std::move(opened);
        handlers_ = std::make_unique<SoilVolumeHandlers>(*store_, nullptr);
    }

    ScratchDir dir_;
    std::unique_ptr<EntryStore> store_;
    std::unique_ptr<SoilVolumeHandlers> handlers_;
};

TEST_F(RpcTableTest, EveryUnaryRpcOfTheServiceHasAHandler) {
    const std::map<std::string, Rpc> table = MakeRpcTable(*handlers_);
    EXPECT_TRUE(CheckRpcTable(table, Api()).ok()) << CheckRpcTable(table, Api());
    int unary = 0;
    for (int i = 0; i < Api().method_count(); ++i) {
        unary += Api().method(i)->client_streaming() ? 0 : 1;
    }
    EXPECT_EQ(static_cast<int>(table.size()), unary);
}

TEST_F(RpcTableTest, AMissingHandlerIsNamed) {
    std::map<std::string, Rpc> table = MakeRpcTable(*handlers_);
    table.erase("GetServerInfo");
    const absl::Status status = CheckRpcTable(table, Api());
    EXPECT_TRUE(absl::IsInternal(status));
    EXPECT_NE(status.message().find("soilvol.v1.SoilVolume.GetServerInfo"), std::string::npos);
}

TEST_F(RpcTableTest, AHandlerOfOtherMessagesIsRefused) {
    std::map<std::string, Rpc> table = MakeRpcTable(*handlers_);
    table["GetContainer"] = table.at("GetCalibration");
    EXPECT_TRUE(absl::IsInternal(CheckRpcTable(table, Api())));
}

}  // namespace
}  // namespace soilvol::server
