#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/entry_store.hpp"

namespace soilvol::server {

/// Decoded entries (e.g. container models) kept in memory, validated against the files on every
/// lookup so that changes made by other processes sharing the data directory are seen.
/// Thread-safe; decoding runs outside the lock. Errors are not cached.
template <typename T>
class EntryCache {
  public:
    using Decoder = std::function<absl::StatusOr<T>(const StoredEntry&)>;
    static constexpr std::size_t kDefaultCapacity = 64;

    /// `store` must outlive the cache; `decode` may run on several threads at once. At most
    /// `capacity` (>= 1) values are kept, the least recently used evicted first.
    EntryCache(const EntryStore& store, Decoder decode, std::size_t capacity = kDefaultCapacity)
        : store_(store), decode_(std::move(decode)), capacity_(capacity > 0 ? capacity : 1) {}

    /// The decoded entry: the cached value when the file's stamp is unchanged, else the file
    /// read and decoded again. NotFound (and the cached value dropped) when the entry is gone;
    /// the store's or the decoder's error otherwise.
    absl::StatusOr<std::shared_ptr<const T>> Get(EntryKind kind, std::string_view id) {
        Key key(kind, std::string(id));
        const absl::StatusOr<FileStamp> stamp = store_.Stat(kind, id);
        if (!stamp.ok()) return Drop(key, stamp.status());
        if (std::shared_ptr<const T> hit = Find(key, *stamp)) return hit;
        // Miss or changed file: read and decode without holding the lock.
        const absl::StatusOr<StoredEntry> entry = store_.Get(kind, id);
        if (!entry.ok()) return Drop(key, entry.status());
        absl::StatusOr<T> decoded = decode_(*entry);
        if (!decoded.ok()) return Drop(key, decoded.status());
        auto value = std::make_shared<const T>(std::move(decoded).value());
        Insert(std::move(key), entry->stamp, value);
        return value;
    }

    /// Number of cached values.
    std::size_t size() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return slots_.size();
    }

  private:
    using Key = std::pair<EntryKind, std::string>;
    struct Slot {
        FileStamp stamp;
        std::shared_ptr<const T> value;
        uint64_t last_use = 0;
    };

    std::shared_ptr<const T> Find(const Key& key, const FileStamp& stamp) {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto it = slots_.find(key);
        if (it == slots_.end() || it->second.stamp != stamp) return nullptr;
        it->second.last_use = ++clock_;
        return it->second.value;
    }

    void Insert(Key key, const FileStamp& stamp, std::shared_ptr<const T> value) {
        std::lock_guard<std::mutex> lock(mutex_);
        slots_[std::move(key)] = Slot{stamp, std::move(value), ++clock_};
        while (slots_.size() > capacity_) {
            auto oldest = slots_.begin();
            for (auto it = slots_.begin(); it != slots_.end(); ++it) {
                if (it->second.last_use < oldest->second.last_use) oldest = it;
            }
            slots_.erase(oldest);
        }
    }

    // A failed lookup means the cached value, if any, no longer matches the file.
    absl::Status Drop(const Key& key, absl::Status status) {
        std::lock_guard<std::mutex> lock(mutex_);
        slots_.erase(key);
        return status;
    }

    const EntryStore& store_;
    const Decoder decode_;
    const std::size_t capacity_;
    mutable std::mutex mutex_;
    std::map<Key, Slot> slots_;
    uint64_t clock_ = 0;
};

}  // namespace soilvol::server
