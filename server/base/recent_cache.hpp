#pragma once

#include <array>
#include <cstddef>
#include <utility>

namespace soilvol::server {

/// A record feed hands each group of at most this many new rows to every watch in turn, all of
/// a group to one watch before the next (RecordFeed::DeliverNew): its stream writes them at
/// once, and a consumer that keeps the values it made of this many rows (RecentCache) makes
/// each once per group, not once per watch.
inline constexpr std::size_t kFeedGroupRows = 16;

/// The values made of the last N keys, oldest replaced first; what Get returns stays valid
/// until N other keys were made. For one thread (a feed's consumers keep one thread_local).
template <typename Key, typename Value, std::size_t N>
class RecentCache {
  public:
    /// The value made of `key`, by `make(key, value&)` unless kept.
    template <typename Make>
    Value& Get(const Key& key, Make&& make) {
        for (Entry& entry : entries_) {
            if (entry.filled && entry.key == key) return entry.value;
        }
        Entry& entry = entries_[next_];
        next_ = (next_ + 1) % N;
        entry.filled = true;
        entry.key = key;
        std::forward<Make>(make)(key, entry.value);
        return entry.value;
    }

  private:
    struct Entry {
        bool filled = false;
        Key key{};
        Value value{};
    };
    std::array<Entry, N> entries_{};
    std::size_t next_ = 0;
};

}  // namespace soilvol::server
