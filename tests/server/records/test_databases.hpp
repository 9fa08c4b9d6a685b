#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <memory>
#include <pqxx/pqxx>
#include <string>

#include "../store/scratch_dir.hpp"
#include "server/records/record_store.hpp"

namespace soilvol::server {

/// A fresh, empty record store of one backend, dropped at scope exit: SQLite in a scratch
/// directory, or a new database on the PostgreSQL server that $SOILVOL_TEST_POSTGRES_URL
/// names (a libpq URI with {db} where the database name goes; .ci/run starts one). Without
/// the variable PostgreSQL tests are skipped, except under CI=true, where they fail.
class TestDatabase {
  public:
    explicit TestDatabase(const std::string& backend) : backend_(backend) {
        if (backend == "sqlite") {
            url_ = "sqlite:" + (scratch_.path() / "records.sqlite3").string();
            return;
        }
        const char* pattern = std::getenv("SOILVOL_TEST_POSTGRES_URL");
        if (pattern == nullptr || *pattern == '\0') {
            const char* ci = std::getenv("CI");
            missing_ = ci != nullptr && std::string(ci) == "true"
                           ? "CI=true but SOILVOL_TEST_POSTGRES_URL is not set"
                           : "";
            skip_ = true;
            return;
        }
        static std::atomic<int> counter{0};
        name_ = "soilvol_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++);
        admin_ = Url(pattern, "postgres");
        url_ = Url(pattern, name_);
        pqxx::connection admin(admin_);
        pqxx::nontransaction work(admin);
        work.exec("DROP DATABASE IF EXISTS " + name_);
        work.exec("CREATE DATABASE " + name_);
    }
    ~TestDatabase() {
        if (name_.empty()) return;
        try {
            pqxx::connection admin(admin_);
            pqxx::nontransaction work(admin);
            work.exec("DROP DATABASE IF EXISTS " + name_ + " WITH (FORCE)");
        } catch (const std::exception&) {
        }
    }

    /// True when the test should stop here (GTEST_SKIP, or a failure under CI).
    bool Unavailable() const {
        if (!skip_) return false;
        if (!missing_.empty()) ADD_FAILURE() << missing_;
        return true;
    }
    const std::string& url() const { return url_; }
    std::unique_ptr<RecordStore> Open() const {
        auto store = OpenRecordStore(url_, scratch_.path());
        EXPECT_TRUE(store.ok()) << store.status();
        return store.ok() ? *std::move(store) : nullptr;
    }

  private:
    static std::string Url(std::string pattern, const std::string& db) {
        const std::size_t at = pattern.find("{db}");
        if (at != std::string::npos) pattern.replace(at, 4, db);
        return pattern;
    }

    std::string backend_, url_, admin_, name_, missing_;
    bool skip_ = false;
    ScratchDir scratch_;
};

#define SOILVOL_NEED_DATABASE(db)        \
    if ((db).Unavailable()) {            \
        GTEST_SKIP() << "no PostgreSQL"; \
    }

}  // namespace soilvol::server
