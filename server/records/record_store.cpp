#include "server/records/record_store.hpp"

#include <regex>

#include "absl/strings/str_cat.h"

namespace soilvol::server {

std::string RedactedUrl(const std::string& url) {
    static const std::regex kPassword(R"(://([^:/@]*):[^@]*@)");
    std::string out = std::regex_replace(url, kPassword, "://$1:***@");
    static const std::regex kQueryPassword(R"(password=[^&]*)");
    return std::regex_replace(out, kQueryPassword, "password=***");
}

absl::StatusOr<std::unique_ptr<RecordStore>> OpenRecordStore(
    const std::string& url, const std::filesystem::path& data_dir) {
    if (url.empty()) return OpenSqliteRecordStore(data_dir / "records.sqlite3");
    if (url.rfind("sqlite:", 0) == 0 && url.size() > 7) return OpenSqliteRecordStore(url.substr(7));
    if (url.rfind("postgres://", 0) == 0 || url.rfind("postgresql://", 0) == 0) {
        return OpenPostgresRecordStore(url);
    }
    return absl::InvalidArgumentError(absl::StrCat(
        "records-url: '", RedactedUrl(url),
        "' is none of sqlite:<path>, postgres://... or postgresql://... (empty: SQLite in the "
        "data directory)"));
}

LoadEventRecord LoadEventOf(const LoadRecord& load, int kind, std::int64_t time_us,
                            std::string container_id) {
    LoadEventRecord event;
    event.kind = kind;
    event.time_us = time_us;
    event.container_id = container_id.empty() ? load.body_container_id : std::move(container_id);
    event.load = load;
    return event;
}

}  // namespace soilvol::server
