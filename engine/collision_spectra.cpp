#include "engine/collision_spectra.h"

#include <algorithm>
#include <cmath>

namespace dem {

namespace {

/// Calls ended(k) for each slot k of `before` whose key `after` does not hold; both keys ascending.
template <class F>
void for_each_ended(const std::vector<std::uint64_t>& before, const std::vector<std::uint64_t>& after, F&& ended) {
  std::size_t j = 0;
  for (std::size_t k = 0; k < before.size(); ++k) {
    while (j < after.size() && after[j] < before[k]) ++j;
    if (j == after.size() || after[j] != before[k]) ended(k);
  }
}

/// Impact energy, normal and tangential (rolling included) loss of one ended contact [J]. As in the
/// World's books: dissipated = work - elastic, the normal work including the step on which the
/// contact parted (contacts.cpp, release_work); the rest of the loss is tangential and rolling.
ContactEvents::Event event_of(CollisionSpectra::Kind kind, const ContactHistory& history, Real work, Real elastic) {
  const double normal = history.normal_work - history.normal_elastic;
  return {kind, {std::max(history.impact_energy, Real(0)), normal, (work - elastic) - normal}};
}

}  // namespace

int CollisionSpectra::bin_of(double energy) {
  if (!(energy > lowest_energy)) return 0;
  const int b = static_cast<int>(std::floor(std::log10(energy / lowest_energy) * bins_per_decade));
  return std::clamp(b, 0, bin_count - 1);
}

double CollisionSpectra::bin_low(int b) { return lowest_energy * std::pow(10.0, static_cast<double>(b) / bins_per_decade); }

void CollisionSpectra::record(Kind kind, const ContactHistory& history, Real work, Real elastic) {
  const ContactEvents::Event e = event_of(kind, history, work, elastic);
  record_event(e.kind, e.value);
}

void CollisionSpectra::record(const ContactEvents& events) {
  for (const ContactEvents::Event& e : events.events()) record_event(e.kind, e.value);
}

void CollisionSpectra::add(const CollisionSpectra& other) {
  for (int kind = 0; kind < kind_count; ++kind) {
    for (int q = 0; q < quantity_count; ++q)
      for (int b = 0; b < bin_count; ++b) {
        histogram_[kind][q].count[b] += other.histogram_[kind][q].count[b];
        histogram_[kind][q].energy[b] += other.histogram_[kind][q].energy[b];
      }
    events_[kind] += other.events_[kind];
  }
  dissipated_ += other.dissipated_;
}

void CollisionSpectra::record_event(Kind kind, const double (&value)[quantity_count]) {
  for (int q = 0; q < quantity_count; ++q) {
    Histogram& h = histogram_[kind][q];
    const int b = bin_of(value[q]);
    ++h.count[b];
    h.energy[b] += value[q];
  }
  ++events_[kind];
  dissipated_ += value[normal_dissipated] + value[tangential_dissipated];
}

void CollisionSpectra::record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
  for_each_ended(before.key, after_key, [&](std::size_t k) { record(ball_ball, before.history(k), before.work[k], before.elastic[k]); });
}

void CollisionSpectra::record_ended(const WallContacts& before, const WallContacts& after) {
  for_each_ended(before.key, after.key, [&](std::size_t k) { record(ball_wall, before.history[k], before.work[k], before.elastic[k]); });
}

void ContactEvents::record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
  for_each_ended(before.key, after_key, [&](std::size_t k) {
    events_.push_back(event_of(CollisionSpectra::ball_ball, before.history(k), before.work[k], before.elastic[k]));
  });
}

void ContactEvents::record_ended(const WallContacts& before, const WallContacts& after) {
  for_each_ended(before.key, after.key, [&](std::size_t k) {
    events_.push_back(event_of(CollisionSpectra::ball_wall, before.history[k], before.work[k], before.elastic[k]));
  });
}

double CollisionSpectra::dissipated() const { return dissipated_; }

double CollisionSpectra::total(Kind kind, Quantity quantity) const {
  double sum = 0;
  for (double e : histogram_[kind][quantity].energy) sum += e;
  return sum;
}

}  // namespace dem
