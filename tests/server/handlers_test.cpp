// SoilVolumeHandlers on a temporary store, without a transport: replayed requests, stale
// etags, concurrent retries of one request and concurrent writers of one entry.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "core/io/cloud_codec.hpp"
#include "core/sim/scene.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "tests/server/store/scratch_dir.hpp"

namespace soilvol::server {
namespace {

// An empty paper bucket seen from its usual viewpoint, with its true opening corners.
const v1::RegisterContainerRequest& EmptyBucket() {
    static const v1::RegisterContainerRequest request = [] {
        sim::SceneSpec spec;
        spec.container = sim::ContainerKind::kPaperBucket;
        spec.sensor = sim::ViewpointFor(spec.container);
        spec.sensor.range_noise_sigma_m = 0.01;
        const sim::Scene scene = sim::SimulateScene(spec);
        v1::RegisterContainerRequest r;
        r.mutable_scan()->mutable_cloud()->set_data(io::EncodePly(scene.points));
        for (const Eigen::Vector3d& c : scene.opening_corners_scan) {
            v1::Point3* p = r.mutable_opening()->add_corners();
            p->set_x(c.x());
            p->set_y(c.y());
            p->set_z(c.z());
        }
        return r;
    }();
    return request;
}

// Runs `call(i)` on `n` threads released together; their statuses by thread.
template <typename Call>
std::vector<absl::Status> AtOnce(int n, Call call) {
    std::atomic<int> ready{0};
    std::vector<absl::Status> results(static_cast<std::size_t>(n));
    std::vector<std::thread> threads;
    for (int i = 0; i < n; ++i) {
        threads.emplace_back([&, i] {
            ++ready;
            while (ready.load() < n) std::this_thread::yield();
            results[static_cast<std::size_t>(i)] = call(i);
        });
    }
    for (std::thread& t : threads) t.join();
    return results;
}

int CountOk(const std::vector<absl::Status>& results) {
    int ok = 0;
    for (const absl::Status& s : results) ok += s.ok();
    return ok;
}

class HandlersTest : public ::testing::Test {
  protected:
    void SetUp() override {
        auto store = EntryStore::Open(dir_.path());
        ASSERT_TRUE(store.ok()) << store.status();
        store_ = *std::move(store);
        handlers_ =
            std::make_unique<SoilVolumeHandlers>(*store_, nullptr, nullptr, nullptr, nullptr);
    }

    absl::StatusOr<v1::Container> Register(const std::string& id, const std::string& request_id,
                                           bool overwrite = false, const std::string& etag = "") {
        v1::RegisterContainerRequest request = EmptyBucket();
        request.set_container_id(id);
        request.set_request_id(request_id);
        request.set_overwrite(overwrite);
        request.set_etag(etag);
        v1::Container container;
        CallRecord record;
        absl::Status status = handlers_->RegisterContainer(request, &container, record);
        if (!status.ok()) return status;
        return container;
    }

    absl::StatusOr<v1::Container> Rename(const std::string& id, const std::string& name,
                                         const std::string& etag) {
        v1::UpdateContainerRequest request;
        request.mutable_container()->set_container_id(id);
        request.mutable_container()->set_display_name(name);
        request.mutable_container()->set_etag(etag);
        request.mutable_update_mask()->add_paths("display_name");
        v1::Container container;
        CallRecord record;
        absl::Status status = handlers_->UpdateContainer(request, &container, record);
        if (!status.ok()) return status;
        return container;
    }

    absl::StatusOr<v1::Container> Get(const std::string& id) {
        v1::GetContainerRequest request;
        request.set_container_id(id);
        v1::Container container;
        CallRecord record;
        absl::Status status = handlers_->GetContainer(request, &container, record);
        if (!status.ok()) return status;
        return container;
    }

    absl::Status Delete(const std::string& id, const std::string& etag) {
        v1::DeleteContainerRequest request;
        request.set_container_id(id);
        request.set_etag(etag);
        v1::DeleteContainerResponse response;
        CallRecord record;
        return handlers_->DeleteContainer(request, &response, record);
    }

    ScratchDir dir_;
    std::unique_ptr<EntryStore> store_;
    std::unique_ptr<SoilVolumeHandlers> handlers_;
};

// AIP-155: the same request id again answers the first result, even where a new request
// would be refused; another request id for a taken id is ALREADY_EXISTS.
TEST_F(HandlersTest, AReplayedRegistrationAnswersTheFirstResult) {
    const auto first = Register("bucket-1", "req-1");
    ASSERT_TRUE(first.ok()) << first.status();
    const auto replay = Register("bucket-1", "req-1");
    ASSERT_TRUE(replay.ok()) << replay.status();
    EXPECT_EQ(replay->etag(), first->etag());
    EXPECT_EQ(replay->struck_capacity_m3(), first->struck_capacity_m3());
    EXPECT_EQ(Register("bucket-1", "req-2").status().code(), absl::StatusCode::kAlreadyExists);
}

// AIP-154: a write or delete at an etag that is no longer current is ABORTED and changes
// nothing; at the current etag it goes through.
TEST_F(HandlersTest, AStaleEtagIsAbortedAndChangesNothing) {
    const auto registered = Register("bucket-1", "");
    ASSERT_TRUE(registered.ok()) << registered.status();
    const std::string e1 = registered->etag();
    const auto renamed = Rename("bucket-1", "Bucket one", e1);
    ASSERT_TRUE(renamed.ok()) << renamed.status();
    const std::string e2 = renamed->etag();
    ASSERT_NE(e1, e2);
    EXPECT_EQ(Rename("bucket-1", "stale", e1).status().code(), absl::StatusCode::kAborted);
    EXPECT_EQ(Register("bucket-1", "", true, e1).status().code(), absl::StatusCode::kAborted);
    EXPECT_EQ(Delete("bucket-1", e1).code(), absl::StatusCode::kAborted);
    const auto now = Get("bucket-1");
    ASSERT_TRUE(now.ok()) << now.status();
    EXPECT_EQ(now->display_name(), "Bucket one");
    EXPECT_EQ(now->etag(), e2);
    EXPECT_TRUE(Delete("bucket-1", e2).ok());
    EXPECT_EQ(Get("bucket-1").status().code(), absl::StatusCode::kNotFound);
}

// Retries of one request racing each other (a client that timed out and sent it again): all
// answer the one entry written.
TEST_F(HandlersTest, ConcurrentRetriesOfOneRequestWriteOnce) {
    std::vector<std::string> etags(4);
    const auto results = AtOnce(4, [&](int i) {
        const auto c = Register("bucket-1", "req-1");
        if (c.ok()) etags[static_cast<std::size_t>(i)] = c->etag();
        return c.status();
    });
    for (const absl::Status& s : results) EXPECT_TRUE(s.ok()) << s;
    const auto stored = Get("bucket-1");
    ASSERT_TRUE(stored.ok()) << stored.status();
    for (const std::string& etag : etags) EXPECT_EQ(etag, stored->etag());
}

// Writers that all hold the current etag: exactly one wins each round, the others are ABORTED,
// and the entry is the winner's (no lost update).
TEST_F(HandlersTest, ConcurrentUpdatesAtOneEtagExactlyOneWins) {
    auto current = Register("bucket-1", "");
    ASSERT_TRUE(current.ok()) << current.status();
    constexpr int kWriters = 6;
    for (int round = 0; round < 5; ++round) {
        const std::string etag = current->etag();
        const auto results = AtOnce(kWriters, [&](int i) {
            return Rename("bucket-1", "r" + std::to_string(round) + "w" + std::to_string(i), etag)
                .status();
        });
        ASSERT_EQ(CountOk(results), 1) << "round " << round;
        int winner = 0;
        for (int i = 0; i < kWriters; ++i) {
            if (results[static_cast<std::size_t>(i)].ok())
                winner = i;
            else
                EXPECT_EQ(results[static_cast<std::size_t>(i)].code(), absl::StatusCode::kAborted);
        }
        current = Get("bucket-1");
        ASSERT_TRUE(current.ok());
        EXPECT_EQ(current->display_name(),
                  "r" + std::to_string(round) + "w" + std::to_string(winner));
    }
}

// Re-registrations at one etag (an overwrite computes a whole new model first): one wins.
TEST_F(HandlersTest, ConcurrentOverwritesAtOneEtagExactlyOneWins) {
    const auto first = Register("bucket-1", "");
    ASSERT_TRUE(first.ok()) << first.status();
    const auto results =
        AtOnce(3, [&](int) { return Register("bucket-1", "", true, first->etag()).status(); });
    EXPECT_EQ(CountOk(results), 1);
    for (const absl::Status& s : results) {
        if (!s.ok()) {
            EXPECT_EQ(s.code(), absl::StatusCode::kAborted) << s;
        }
    }
}

// Updates without an etag of different fields that race each other are applied one after
// the other: neither is lost.
TEST_F(HandlersTest, ConcurrentUpdatesWithoutEtagLoseNothing) {
    ASSERT_TRUE(Register("bucket-1", "").ok());
    for (int round = 0; round < 10; ++round) {
        const std::string tag = std::to_string(round);
        const auto results = AtOnce(2, [&](int i) {
            v1::UpdateContainerRequest request;
            request.mutable_container()->set_container_id("bucket-1");
            if (i == 0) {
                request.mutable_container()->set_display_name("name " + tag);
                request.mutable_update_mask()->add_paths("display_name");
            } else {
                request.mutable_container()->mutable_material()->set_name("clay " + tag);
                request.mutable_update_mask()->add_paths("material.name");
            }
            v1::Container container;
            CallRecord record;
            return handlers_->UpdateContainer(request, &container, record);
        });
        for (const absl::Status& s : results) ASSERT_TRUE(s.ok()) << s;
        const auto stored = Get("bucket-1");
        ASSERT_TRUE(stored.ok());
        EXPECT_EQ(stored->display_name(), "name " + tag);
        EXPECT_EQ(stored->material().name(), "clay " + tag);
    }
}

// Deletes at one etag: one deletes, the others find it gone or changed.
TEST_F(HandlersTest, ConcurrentDeletesAtOneEtagDeleteOnce) {
    const auto c = Register("bucket-1", "");
    ASSERT_TRUE(c.ok()) << c.status();
    const auto results = AtOnce(4, [&](int) { return Delete("bucket-1", c->etag()); });
    EXPECT_EQ(CountOk(results), 1);
    for (const absl::Status& s : results) {
        if (!s.ok()) {
            EXPECT_EQ(s.code(), absl::StatusCode::kNotFound) << s;
        }
    }
}

}  // namespace
}  // namespace soilvol::server
