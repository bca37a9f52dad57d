#include "stream/stream_policy.h"

#include <algorithm>

namespace rgbdcast::stream {

namespace {
// A budget that beats `base` by 1.25 x and 8 kB: a refinement worth its trip over the line.
bool beats(double budget_kb, double base_kb) { return budget_kb >= std::max(1.25 * base_kb, base_kb + 8); }
}  // namespace

KeyframeBudget plan_keyframe_budget(const LinkSnapshot& link, const KeyframeBudgetInput& in, const BudgetRule& rule,
                                    const LatencyRule& latency, double coarse_factor) {
  KeyframeBudget out;
  out.overhead_s = std::max(0.0, in.age_s) + in.reduce_s + link.queue_wait_s +
                   (link.acknowledged_posts == 0 ? latency.first_post_fixed_s : 0.0);
  const double rate_fixed_s = link.lanes > 1 ? 0.0 : link.post_fixed_s;
  const double rate_kb = keyframe_budget_kb(link.line_kbps, in.interval_s, rule, rate_fixed_s);
  out.budget_kb =
      in.deferred
          ? std::max(rule.floor_kb, coarse_factor * rate_kb)
          : std::min(rate_kb, latency_budget_kb(link.line_kbps, out.overhead_s, latency, rule, link.post_fixed_s));
  return out;
}

double carried_kb(const RefineLimits& limits, double window_s, double line_kbps, double fixed_s) {
  return refinement_budget_kb(line_kbps, std::min(window_s, limits.window_s), fixed_s, limits.ceiling_kb,
                              limits.headroom);
}

std::optional<double> beside_keyframe_budget_kb(const LinkSnapshot& link, const RefineLimits& limits,
                                                double keyframe_kb, bool deferred) {
  if (deferred || !(limits.ceiling_kb > 0) || !(link.cap_kbps > 0) || !link.refinements_yield ||
      link.acknowledged_posts != 0)
    return std::nullopt;
  const double kb = carried_kb(limits, limits.window_s, link.cap_kbps, 0.0);
  if (!beats(kb, keyframe_kb)) return std::nullopt;
  return kb;
}

bool refine_right_after_keyframe(const LinkSnapshot& link, bool written, bool queues_empty) {
  return written && queues_empty && link.acknowledged_posts == 0 && link.cap_kbps > 0 && link.refinements_yield;
}

double room_owed_s(double expected_s) { return std::max(expected_s, 0.1); }

bool link_has_room(double owed_s, double expected_s) { return owed_s <= room_owed_s(expected_s); }

bool hold_keyframe(bool supersede, double owed_s, double reduce_s) {
  return supersede && !link_has_room(owed_s, reduce_s);
}

bool tracker_may_go_on(bool holding, size_t keyframes_waiting, bool reducing) {
  return holding || (keyframes_waiting == 0 && !reducing);
}

CoarsenPlan::CoarsenPlan(std::vector<OutboxEntry> entries, int newest, double estimate_kbps, double interval_s,
                         const CoarsenRule& rule)
    : entries_(std::move(entries)),
      newest_(newest),
      estimate_kbps_(std::max(estimate_kbps, 1.0)),
      limit_s_(std::max(rule.max_backlog_s, 2.0 * interval_s)),
      rule_(rule) {
  for (const OutboxEntry& e : entries_)
    if (e.pending() && e.rev == 0) pending_bytes_ += static_cast<double>(e.bytes);  // refinements go last anyway
}

double CoarsenPlan::backlog_s() const { return pending_bytes_ * 8.0 / 1000.0 / estimate_kbps_; }

std::optional<CoarsenStep> CoarsenPlan::next() {
  while (at_ < entries_.size()) {
    if (backlog_s() <= limit_s_) return std::nullopt;
    const OutboxEntry& e = entries_[at_++];
    if (!e.pending() || e.attempted || e.coarsened || e.rev > 0 || e.seq == newest_) continue;
    const double target_kb = std::max(rule_.floor_kb, e.budget_kb * rule_.coarse_factor);
    if (target_kb * 1000.0 >= 0.9 * static_cast<double>(e.bytes)) continue;  // already about that small
    return CoarsenStep{e.seq, target_kb};
  }
  return std::nullopt;
}

void CoarsenPlan::shrunk_by(size_t bytes) { pending_bytes_ -= static_cast<double>(bytes); }

RefinementPlanner::Result RefinementPlanner::choose(const std::vector<OutboxEntry>& entries, const LinkSnapshot& link,
                                                    const RefineQuery& query) {
  Result out;
  if (!(limits_.ceiling_kb > 0)) return out;
  const double measured_kb = carried_kb(limits_, query.window_s, link.line_kbps, link.post_fixed_s);
  // Without a cap, ahead only once an answer has measured the link: a budget from the initial guess would be
  // replaced by the next refinement as soon as the link is known. Under a cap, before that answer, at the cap's
  // budget (checked against the measured link when the answer comes: judge_refinement).
  const bool measured = link.acknowledged_posts > 0;
  const bool from_cap = !measured && link.cap_kbps > 0;
  const double ahead_kb = from_cap ? carried_kb(limits_, query.window_s, link.cap_kbps, 0.0) : measured_kb;
  std::optional<RefineChoice> best;
  for (bool answered : {true, false}) {
    if (best || (!answered && !(query.ahead && (measured || from_cap) && !link.link_down))) break;
    const double kb = answered ? measured_kb : ahead_kb;
    for (const OutboxEntry& e : entries) {
      const auto tried = tried_.find(e.seq);
      const double base = std::max(e.budget_kb, tried == tried_.end() ? 0.0 : tried->second);
      // Ahead from the cap, a keyframe just added qualifies before its lane marks it attempted (by the time its
      // refinement is reduced it is: the sender takes a keyframe at once when nothing else waits).
      const bool state =
          answered ? e.acked : (!e.acked && (e.attempted || (from_cap && e.rev == 0)) && e.rejected.empty());
      if (!state || (query.only_seq >= 0 && e.seq != query.only_seq) || !beats(kb, base)) continue;
      if (saturated(e, kb)) {
        if (saturated_seen_.insert({e.seq, e.rev}).second) ++out.newly_saturated;
        continue;
      }
      if (!best || e.captured > best->entry.captured ||
          (e.captured == best->entry.captured && e.seq > best->entry.seq)) {
        best = RefineChoice{e, kb, !e.acked, !e.acked && from_cap, 0};
      }
    }
  }
  if (best) {
    tried_[best->entry.seq] = best->budget_kb;
    best->newly_saturated = out.newly_saturated;
  }
  out.chosen = std::move(best);
  return out;
}

void RefinementPlanner::note_revision(int seq, size_t bytes, double budget_kb, bool fits) {
  if (fits)
    fits_[seq] = {bytes, budget_kb};
  else
    fits_.erase(seq);
}

bool RefinementPlanner::saturated(const OutboxEntry& e, double budget_kb) const {
  const auto f = fits_.find(e.seq);
  if (f == fits_.end() || f->second.bytes != e.bytes || f->second.budget_kb != e.budget_kb) return false;
  const double above = fine_above_kb_;
  return !(above > 0) || (budget_kb > above) == (f->second.budget_kb > above);
}

RefinementVerdict judge_refinement(size_t bytes, size_t replaced_bytes, bool made_from_cap, bool answered,
                                   double measured_carried_kb) {
  if (static_cast<double>(bytes) < kRefinementKeepRatio * static_cast<double>(replaced_bytes))
    return RefinementVerdict::kTooSmall;
  if (made_from_cap && answered && static_cast<double>(bytes) > 1000.0 * measured_carried_kb)
    return RefinementVerdict::kRedoMeasured;
  return RefinementVerdict::kKeep;
}

double refiner_window_s(const LinkSnapshot& link, double window_s, double last_keyframe_s, double interval_s,
                        double reduce_s, double refine_s, double now_s) {
  if (link.refinements_yield) return window_s;
  return last_keyframe_s + interval_s + reduce_s - now_s - refine_s;
}

ResumePlan plan_resume(const std::vector<OutboxEntry>& entries, const std::vector<DeferredKeyframe>& deferred) {
  ResumePlan plan;
  if (entries.empty() && deferred.empty()) return plan;
  plan.resumed = true;
  for (const OutboxEntry& e : entries)
    if (e.frame_index > plan.at_frame) {
      plan.at_frame = e.frame_index;
      plan.anchor = e.pose;
    }
  if (!deferred.empty() && deferred.back().frame_index > plan.at_frame) {
    plan.at_frame = deferred.back().frame_index;
    plan.anchor = deferred.back().pose;
  }
  for (const OutboxEntry& e : entries)
    if (e.rejected.empty()) plan.view_seqs.push_back(e.seq);
  return plan;
}

bool refiner_may_refine(const RefinerTurn& t) {
  return !t.keyframe_work && t.keyframes > 0 && t.window_s > 0 && t.owed_s <= kRefinerOwedS;
}

bool post_start_settled(const std::optional<OutboxEntry>& now, int rev) {
  return !now || now->rev != rev || !now->pending() || now->attempted;
}

bool revise_beside_post(const std::optional<OutboxEntry>& now, int rev) {
  return now && now->rev == rev && now->attempted && now->pending();
}

AheadStep refinement_ahead_step(const AheadSnapshot& s) {
  if (!s.waits) return s.now && s.now->acked && s.now->rev == s.rev ? AheadStep::kAdd : AheadStep::kRedoLater;
  if (!s.now || !s.now->rejected.empty() || s.now->rev != s.rev) return AheadStep::kDrop;
  if (s.now->acked) return AheadStep::kAdd;
  if (s.stopping) return AheadStep::kDrop;
  if (s.link_down) return AheadStep::kRedoLater;
  return AheadStep::kWait;
}

}  // namespace rgbdcast::stream
