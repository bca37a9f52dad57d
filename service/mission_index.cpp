#include "service/mission_index.h"

#include <algorithm>

namespace rgbdcast::service {

std::optional<MissionKeyframe> MissionIndex::find(const std::string& name, std::int64_t seq) const {
  std::lock_guard lock(mutex_);
  auto m = missions_.find(name);
  if (m == missions_.end()) return std::nullopt;
  auto it = m->second.by_seq.find(seq);
  if (it == m->second.by_seq.end()) return std::nullopt;
  return it->second;
}

bool MissionIndex::contains(const std::string& name) const {
  std::lock_guard lock(mutex_);
  return missions_.count(name) > 0;
}

bool MissionIndex::upsert(const MissionKeyframe& k) {
  std::lock_guard lock(mutex_);
  auto [m, created] = missions_.try_emplace(k.mission);
  if (created) m->second.generation = next_generation_++;
  auto it = m->second.by_seq.find(k.seq);
  if (it != m->second.by_seq.end() && it->second.rev >= k.rev) return created;
  m->second.by_seq[k.seq] = k;
  return true;
}

bool MissionIndex::set_available(const std::string& name, std::int64_t seq, std::int64_t rev, double available) {
  {
    std::lock_guard lock(mutex_);
    auto m = missions_.find(name);
    if (m == missions_.end()) return false;
    auto it = m->second.by_seq.find(seq);
    if (it == m->second.by_seq.end() || it->second.rev != rev || it->second.available > 0) return false;
    it->second.available = available;
    if (it->second.first_available <= 0) it->second.first_available = available;
    if (!m->second.arrived.emplace(seq, rev).second) return false;
    m->second.arrival.push_back(it->second);
  }
  changed_.notify_all();
  return true;
}

void MissionIndex::load(const std::string& name, std::map<std::int64_t, MissionKeyframe> by_seq, double now_unix_s) {
  Mission m;
  m.by_seq = std::move(by_seq);
  std::vector<const MissionKeyframe*> order;
  for (auto& [seq, k] : m.by_seq) {
    if (k.available <= 0) k.available = now_unix_s;
    if (k.first_available <= 0) k.first_available = k.available;
    order.push_back(&k);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const MissionKeyframe* a, const MissionKeyframe* b) { return a->available < b->available; });
  for (const auto* k : order) {
    m.arrival.push_back(*k);
    m.arrived.emplace(k->seq, k->rev);
  }
  {
    std::lock_guard lock(mutex_);
    m.generation = next_generation_++;
    missions_[name] = std::move(m);
  }
  changed_.notify_all();
}

bool MissionIndex::erase(const std::string& name) {
  {
    std::lock_guard lock(mutex_);
    if (!missions_.erase(name)) return false;
  }
  changed_.notify_all();
  return true;
}

std::vector<MissionSummary> MissionIndex::list() const {
  std::vector<MissionSummary> out;
  std::lock_guard lock(mutex_);
  for (const auto& [name, m] : missions_) {
    MissionSummary s;
    s.name = name;
    s.keyframes = m.by_seq.size();
    for (const auto& [seq, k] : m.by_seq) {
      s.bytes += k.bytes;
      s.updated = std::max(s.updated, k.received);
    }
    out.push_back(s);
  }
  return out;
}

std::optional<std::vector<MissionKeyframe>> MissionIndex::keyframes(const std::string& name) const {
  std::lock_guard lock(mutex_);
  auto m = missions_.find(name);
  if (m == missions_.end()) return std::nullopt;
  std::vector<MissionKeyframe> out;
  for (const auto& [seq, k] : m->second.by_seq) out.push_back(k);
  return out;
}

std::optional<std::vector<MissionKeyframe>> MissionIndex::arrivals(const std::string& name) const {
  std::lock_guard lock(mutex_);
  auto m = missions_.find(name);
  if (m == missions_.end()) return std::nullopt;
  return m->second.arrival;
}

std::optional<EventCursor> MissionIndex::cursor_after(const std::string& name,
                                                      std::optional<MissionEventId> last_event_id) const {
  std::lock_guard lock(mutex_);
  auto m = missions_.find(name);
  if (m == missions_.end()) return std::nullopt;
  EventCursor c;
  c.generation = m->second.generation;
  if (last_event_id) {
    const auto& a = m->second.arrival;
    auto it = std::find_if(a.begin(), a.end(), [&](const MissionKeyframe& k) {
      return k.seq == last_event_id->seq && k.rev == last_event_id->rev;
    });
    if (it != a.end()) c.next = static_cast<size_t>(it - a.begin()) + 1;
  }
  return c;
}

EventBatch MissionIndex::wait_events(const std::string& name, EventCursor& cursor, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  EventBatch batch;
  auto ready = [&] {
    auto m = missions_.find(name);
    if (m == missions_.end() || m->second.generation != cursor.generation) return true;
    return m->second.arrival.size() > cursor.next || m->second.tileset_version != cursor.tileset_version || stopped_;
  };
  changed_.wait_for(lock, timeout, ready);
  auto m = missions_.find(name);
  if (m == missions_.end() || m->second.generation != cursor.generation) return batch;
  batch.exists = true;
  for (; cursor.next < m->second.arrival.size(); ++cursor.next) batch.events.push_back(m->second.arrival[cursor.next]);
  if (m->second.tileset_version != cursor.tileset_version) {
    cursor.tileset_version = m->second.tileset_version;
    batch.tileset_version = cursor.tileset_version;
  }
  return batch;
}

void MissionIndex::set_tileset_version(const std::string& name, std::uint64_t version) {
  {
    std::lock_guard lock(mutex_);
    auto m = missions_.find(name);
    if (m == missions_.end()) return;
    m->second.tileset_version = version;
  }
  changed_.notify_all();
}

void MissionIndex::wake_all() {
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  changed_.notify_all();
}

size_t MissionIndex::count() const {
  std::lock_guard lock(mutex_);
  return missions_.size();
}

}  // namespace rgbdcast::service
