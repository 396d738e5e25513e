// Per-robot sessions (proto LocaliseRequest.session): the sequence filter's state
// (common/matching/sequence_filter.h) of every live session, kept in the server.
//
// A session is named by the client and keyed by (client key name, map name, session name):
// with auth.enabled, one robot's key cannot reach another key's sessions. The state is
// bounded: at most max_sessions live and max_state_bytes of states (the least recently
// used are dropped first), a session unused for idle_timeout_s is dropped, and a session whose map
// was reloaded with other places since its last frame (another Map::PlacesKey: another tour, new
// ground) starts again; a reload that keeps the places (the same file, or the map extended by a
// walk of its route) continues it.
//
// The store is half of where a session lives: every reply also carries the state
// (session_token.h) and a request that sends it back continues from it (SessionSeed), so
// a session survives eviction, expiry, a restart, and frames answered by another process
// (docs/sessions.md says why both).
//
// Thread-safe: Update may run on any number of threads at once. The store's mutex guards
// the table of sessions and is held only to find, add or drop one; each session has its own
// mutex, held for its filter update (39 µs a frame at 200 locations, 2.6 ms at 10,000:
// docs/results.md), so frames of different sessions are filtered in parallel and frames of
// one session one after the other.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <string>
#include <unordered_map>

#include "common/matching/sequence_filter.h"
#include "common/util/mutex.h"
#include "common/util/settings.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"
#include "proto/wire.h"

namespace sceneloc {

struct SessionOptions {
  // Live sessions at most, all maps; a new session beyond it drops the least recently used.
  int64_t max_sessions = 10000;
  // A session unused this long is dropped, seconds (> 0).
  double idle_timeout_s = 600;
  // The sessions' filter states together at most, bytes: a state holds a float per tour
  // location and the speeds of the tracked ones (sequence_filter.h), so 10,000 sessions on
  // a 5,000-location map would be 247 MB. Past it the
  // least recently used are dropped (the one just updated is always kept). Their clients
  // still continue from the state their replies carry.
  int64_t max_state_bytes = int64_t{64} << 20;

  // The ranges of SessionSettings.
  Status Validate() const;
};

// The server's sessions: section, bound to `o`.
SettingTable SessionSettings(SessionOptions* o);

enum class SessionStart { kContinued, kNew, kReset, kMapReloaded };

// What a request says about where its session continues from.
struct SessionSeed {
  bool reset = false;      // start again (reset_session)
  bool other_map = false;  // it carried a state of another map: start again
  // A state it carried (session_token.h), which replaces the store's; null = none.
  const SequenceState* carried = nullptr;
};

struct SessionCounts {
  size_t live = 0;
  size_t memory_bytes = 0;  // states, keys and bookkeeping
  uint64_t evicted = 0;
  uint64_t expired = 0;
};

class SessionStore {
 public:
  using Clock = std::chrono::steady_clock;
  // REQUIRES: options.Validate().ok().
  explicit SessionStore(const SessionOptions& options);

  // Runs `step` on the state of session (client, map, name) on the map of places `map_key`,
  // under that session's lock (not the store's): on seed.carried when given; on a fresh state after
  // a reset, a state of another map, for a session the store does not hold, or one that last ran on
  // a map of other places; on its stored state otherwise. Keeps the result. Drops
  // the sessions idle past the timeout and, for a new session when full or when the states
  // pass max_state_bytes, the least recently used. Returns how the session began (CONTINUED for a
  // carried state). A session dropped while its frame is filtered loses that frame's state
  // from the store (its reply still carries it).
  SessionStart Update(const std::string& client, const std::string& map, const std::string& name,
                      uint32_t map_key, const SessionSeed& seed, Clock::time_point now,
                      const std::function<void(SequenceState*)>& step) EXCLUDES(mutex_);

  SessionCounts Counts() const EXCLUDES(mutex_);

 private:
  // One session's filter state, shared by the table and the updates running on it (an
  // update keeps it alive if the session is dropped meanwhile).
  struct Slot {
    Mutex mutex;
    SequenceState state GUARDED_BY(mutex);
    uint32_t map_key GUARDED_BY(mutex) = 0;  // Map::PlacesKey of its last frame's map
    bool fresh GUARDED_BY(mutex) = true;     // no frame filtered yet
  };
  struct Entry {
    std::shared_ptr<Slot> slot;
    size_t state_bytes = 0;  // the slot's state as last counted into state_bytes_
    Clock::time_point last_used;
    std::list<std::string>::iterator lru;  // its place in lru_
  };

  // The session's slot, added (dropping the least recently used when full) if new; marks it
  // the most recently used.
  std::shared_ptr<Slot> Find(std::string key, Clock::time_point now) EXCLUDES(mutex_);
  // Counts the state `slot` now holds, if `key` still names it, and drops the least
  // recently used others while the states pass max_state_bytes.
  void Recount(const std::string& key, const Slot* slot, size_t state_bytes) EXCLUDES(mutex_);
  void DropIdle(Clock::time_point now) REQUIRES(mutex_);
  void DropLeastRecentlyUsed() REQUIRES(mutex_);
  void Erase(std::unordered_map<std::string, Entry>::iterator it) REQUIRES(mutex_);

  // Constant after construction.
  const SessionOptions options_;

  mutable Mutex mutex_;
  // Guarded by mutex_.
  std::unordered_map<std::string, Entry> sessions_ GUARDED_BY(mutex_);
  std::list<std::string> lru_ GUARDED_BY(mutex_);  // keys, most recently used first
  size_t state_bytes_ GUARDED_BY(mutex_) = 0;      // sum of the states' belief sizes, bytes
  uint64_t evicted_ GUARDED_BY(mutex_) = 0;
  uint64_t expired_ GUARDED_BY(mutex_) = 0;
};

}  // namespace sceneloc
