#include "server/session_store.h"

#include <cmath>

namespace sceneloc {
namespace {

// Client, map and session name joined by a byte none of them can hold (names are checked
// printable; key names and map names hold no NUL).
std::string Key(const std::string& client, const std::string& map, const std::string& name) {
  std::string key;
  key.reserve(client.size() + map.size() + name.size() + 2);
  key.append(client).push_back('\0');
  key.append(map).push_back('\0');
  key.append(name);
  return key;
}

size_t BeliefBytes(const SequenceState& state) { return state.MemoryBytes(); }

}  // namespace

SettingTable SessionSettings(SessionOptions* o) {
  return {
      Setting("sessions", "max_sessions", &o->max_sessions)
          .Range(1, 1e9)
          .Help("live sessions at most; a new one beyond drops the least recently used")
          .Flag("max-sessions"),
      Setting("sessions", "idle_timeout_s", &o->idle_timeout_s)
          .Range(1e-3, 1e9)
          .Unit("s")
          .Help("a session unused this long is dropped")
          .Flag("session-idle-timeout"),
      Setting("sessions", "max_state_bytes", &o->max_state_bytes)
          .Range(1, 1e15)
          .Unit("bytes")
          .Help("filter states together at most (a float per tour location each, and the "
                "speeds of the tracked ones); past it the least recently used are dropped")
          .Flag("max-session-bytes"),
  };
}

Status SessionOptions::Validate() const {
  SessionOptions copy = *this;
  return CheckSettings(SessionSettings(&copy));
}

SessionStore::SessionStore(const SessionOptions& options) : options_(options) {}

void SessionStore::Erase(std::unordered_map<std::string, Entry>::iterator it) {
  state_bytes_ -= it->second.state_bytes;
  lru_.erase(it->second.lru);
  sessions_.erase(it);
}

void SessionStore::DropIdle(Clock::time_point now) {
  const auto timeout = std::chrono::duration<double>(options_.idle_timeout_s);
  while (!lru_.empty()) {
    const auto it = sessions_.find(lru_.back());
    if (now - it->second.last_used < timeout) break;
    Erase(it);
    ++expired_;
  }
}

void SessionStore::DropLeastRecentlyUsed() {
  Erase(sessions_.find(lru_.back()));
  ++evicted_;
}

std::shared_ptr<SessionStore::Slot> SessionStore::Find(std::string key, Clock::time_point now) {
  MutexLock lock(&mutex_);
  DropIdle(now);
  auto it = sessions_.find(key);
  if (it == sessions_.end()) {
    if (sessions_.size() >= static_cast<size_t>(options_.max_sessions)) DropLeastRecentlyUsed();
    lru_.push_front(key);
    it = sessions_.emplace(std::move(key), Entry{}).first;
    it->second.slot = std::make_shared<Slot>();
    it->second.lru = lru_.begin();
  } else {
    lru_.splice(lru_.begin(), lru_, it->second.lru);
  }
  it->second.last_used = now;
  return it->second.slot;
}

void SessionStore::Recount(const std::string& key, const Slot* slot, size_t state_bytes) {
  MutexLock lock(&mutex_);
  const auto it = sessions_.find(key);
  if (it == sessions_.end() || it->second.slot.get() != slot) return;  // dropped meanwhile
  state_bytes_ = state_bytes_ - it->second.state_bytes + state_bytes;
  it->second.state_bytes = state_bytes;
  // Everything behind this session in lru_ was used less recently; never drop it here.
  while (state_bytes_ > static_cast<size_t>(options_.max_state_bytes) && lru_.back() != key) {
    DropLeastRecentlyUsed();
  }
}

SessionStart SessionStore::Update(const std::string& client, const std::string& map,
                                  const std::string& name, uint32_t map_key,
                                  const SessionSeed& seed, Clock::time_point now,
                                  const std::function<void(SequenceState*)>& step) {
  const std::string key = Key(client, map, name);
  const std::shared_ptr<Slot> slot = Find(key, now);
  SessionStart start = SessionStart::kContinued;
  size_t state_bytes = 0;
  {
    MutexLock lock(&slot->mutex);
    if (slot->fresh) {
      start = SessionStart::kNew;
    } else if (slot->map_key != map_key) {
      start = SessionStart::kMapReloaded;
    }
    if (seed.reset) {
      start = SessionStart::kReset;
    } else if (seed.other_map) {
      start = SessionStart::kMapReloaded;
    } else if (seed.carried != nullptr) {
      start = SessionStart::kContinued;
    }
    if (start != SessionStart::kContinued) {
      slot->state = SequenceState{};
    } else if (seed.carried != nullptr) {
      slot->state = *seed.carried;
    }
    slot->map_key = map_key;
    slot->fresh = false;
    step(&slot->state);
    state_bytes = BeliefBytes(slot->state);
  }
  Recount(key, slot.get(), state_bytes);
  return start;
}

SessionCounts SessionStore::Counts() const {
  MutexLock lock(&mutex_);
  SessionCounts c;
  c.live = sessions_.size();
  // Per session: the state, the key twice (map node and LRU list node), the slot with its
  // shared_ptr control block, and the nodes.
  size_t keys = 0;
  for (const std::string& k : lru_) keys += 2 * k.capacity();
  c.memory_bytes =
      state_bytes_ + keys +
      sessions_.size() * (sizeof(Entry) + sizeof(Slot) + sizeof(std::string) + 6 * sizeof(void*));
  c.evicted = evicted_;
  c.expired = expired_;
  return c;
}

}  // namespace sceneloc
