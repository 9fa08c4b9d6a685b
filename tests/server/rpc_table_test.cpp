#include "server/handlers/rpc_table.hpp"

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
        handlers_ =
            std::make_unique<SoilVolumeHandlers>(*store_, nullptr, nullptr, nullptr, nullptr);
    }

    ScratchDir dir_;
    std::unique_ptr<EntryStore> store_;
    std::unique_ptr<SoilVolumeHandlers> handlers_;
};

TEST_F(RpcTableTest, EveryUnaryRpcOfTheServiceHasAHandler) {
    const std::map<std::string, Rpc> table = MakeRpcTable(*handlers_);
    EXPECT_TRUE(CheckRpcTable(table, Api()).ok()) << CheckRpcTable(table, Api());
    int unary = 0;
    int server_streaming = 0;
    for (int i = 0; i < Api().method_count(); ++i) {
        const google::protobuf::MethodDescriptor& method = *Api().method(i);
        unary += method.client_streaming() || method.server_streaming() ? 0 : 1;
        server_streaming += !method.client_streaming() && method.server_streaming() ? 1 : 0;
    }
    EXPECT_EQ(static_cast<int>(table.size()), unary);
    // Every server-streaming RPC is in the stream table (gRPC writes, REST sends SSE).
    const std::map<std::string, StreamRpc> streams = MakeStreamTable(*handlers_);
    EXPECT_EQ(static_cast<int>(streams.size()), server_streaming);
    for (const auto& [name, stream] : streams) {
        const google::protobuf::MethodDescriptor* method = Api().FindMethodByName(name);
        ASSERT_NE(method, nullptr) << name;
        EXPECT_EQ(stream.new_request()->GetDescriptor(), method->input_type());
        EXPECT_NE(method->output_type()->FindFieldByName(stream.id_field), nullptr);
        EXPECT_NE(method->input_type()->FindFieldByName(stream.resume_field), nullptr);
    }
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
