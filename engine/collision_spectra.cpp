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

/// The same for wall lists, ordered by particle slot, then key.
template <class F>
void for_each_ended_wall(const WallContacts& before, const WallContacts& after, F&& ended) {
  const auto precedes = [](const WallContacts& a, std::size_t p, const WallContacts& b, std::size_t q) {
    return a.particle[p] < b.particle[q] || (a.particle[p] == b.particle[q] && a.key[p] < b.key[q]);
  };
  std::size_t j = 0;
  for (std::size_t k = 0; k < before.size(); ++k) {
    while (j < after.size() && precedes(after, j, before, k)) ++j;
    if (j == after.size() || after.particle[j] != before.particle[k] || after.key[j] != before.key[k]) ended(k);
  }
}

/// Impact energy, normal and tangential (rolling included) loss of one ended contact [J]. As in the
/// World's books: dissipated = work - elastic, the normal work including the step on which the
/// contact parted (contacts.cpp, release_work); the rest of the loss is tangential and rolling.
ContactEvents::Event event_of(std::uint64_t key, bool wall, const ContactHistory& history, Real work, Real elastic) {
  const double normal = history.normal_work - history.normal_elastic;
  return {key, wall, {std::max(history.impact_energy, Real(0)), normal, (work - elastic) - normal}};
}

}  // namespace

CollisionSpectra::CollisionSpectra(std::vector<double> edges) : edges_(std::move(edges)) {
  if (class_count() > max_classes) edges_.resize(max_classes - 1);
  histogram_.resize(static_cast<std::size_t>(kind_count()) * quantity_count);
  events_.assign(static_cast<std::size_t>(kind_count()), 0);
}

int CollisionSpectra::class_of_radius(Real radius) const {
  return static_cast<int>(std::upper_bound(edges_.begin(), edges_.end(), radius) - edges_.begin());
}

void CollisionSpectra::classify(ParticleId id, Real radius) {
  if (edges_.empty()) return;  // one class: every id is class 0
  if (id >= class_of_id_.size()) class_of_id_.resize(std::size_t{id} + 1, 0);
  class_of_id_[id] = static_cast<std::uint8_t>(class_of_radius(radius));
}

CollisionSpectra::Kind CollisionSpectra::pair_kind(int a, int b) const {
  if (a > b) std::swap(a, b);
  // Kinds before row a: n + (n - 1) + ... + (n - a + 1).
  return a * class_count() - a * (a - 1) / 2 + (b - a);
}

std::array<int, 2> CollisionSpectra::classes_of(Kind kind) const {
  const int n = class_count();
  const int pairs = n * (n + 1) / 2;
  if (kind >= pairs) return {kind - pairs, -1};
  for (int a = 0; a < n; ++a)
    if (kind < pair_kind(a, n - 1) + 1) return {a, a + (kind - pair_kind(a, a))};
  return {0, 0};
}

std::string CollisionSpectra::class_name(int c) const {
  if (class_count() == 1) return "ball";
  std::string name = "c";  // appended, not "c" + ...: GCC 12's -Wrestrict misreads that at -O3
  name += std::to_string(c);
  return name;
}

std::string CollisionSpectra::kind_name(Kind kind) const {
  const std::array<int, 2> c = classes_of(kind);
  return class_name(c[0]) + "-" + (c[1] < 0 ? std::string("liner") : class_name(c[1]));
}

int CollisionSpectra::bin_of(double energy) {
  if (!(energy > lowest_energy)) return 0;
  const int b = static_cast<int>(std::floor(std::log10(energy / lowest_energy) * bins_per_decade));
  return std::clamp(b, 0, bin_count - 1);
}

double CollisionSpectra::bin_low(int b) { return lowest_energy * std::pow(10.0, static_cast<double>(b) / bins_per_decade); }

void CollisionSpectra::record_pair(std::uint64_t key, const ContactHistory& history, Real work, Real elastic) {
  const ContactEvents::Event e = event_of(key, false, history, work, elastic);
  record_event(kind_of_pair_key(key), e.value);
}

void CollisionSpectra::record_wall(std::uint64_t key, const ContactHistory& history, Real work, Real elastic) {
  const ContactEvents::Event e = event_of(key, true, history, work, elastic);
  record_event(kind_of_wall_key(key), e.value);
}

void CollisionSpectra::record(const ContactEvents& events) {
  for (const ContactEvents::Event& e : events.events())
    record_event(e.wall ? kind_of_wall_key(e.key) : kind_of_pair_key(e.key), e.value);
}

void CollisionSpectra::record_event(Kind kind, const double (&value)[quantity_count]) {
  for (int q = 0; q < quantity_count; ++q) {
    Histogram& h = histogram_[static_cast<std::size_t>(kind) * quantity_count + q];
    const int b = bin_of(value[q]);
    ++h.count[b];
    h.energy[b] += value[q];
  }
  ++events_[static_cast<std::size_t>(kind)];
  dissipated_ += value[normal_dissipated] + value[tangential_dissipated];
}

void CollisionSpectra::record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
  for_each_ended(before.key, after_key,
                 [&](std::size_t k) { record_pair(before.key[k], before.history(k), before.work[k], before.elastic[k]); });
}

void CollisionSpectra::record_ended(const WallContacts& before, const WallContacts& after) {
  for_each_ended_wall(before, after,
                     [&](std::size_t k) { record_wall(before.key[k], before.history[k], before.work[k], before.elastic[k]); });
}

void ContactEvents::record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
  for_each_ended(before.key, after_key, [&](std::size_t k) {
    events_.push_back(event_of(before.key[k], false, before.history(k), before.work[k], before.elastic[k]));
  });
}

void ContactEvents::record_ended(const WallContacts& before, const WallContacts& after) {
  for_each_ended_wall(before, after, [&](std::size_t k) {
    events_.push_back(event_of(before.key[k], true, before.history[k], before.work[k], before.elastic[k]));
  });
}

void ContactEvents::record_pair(std::uint64_t key, const ContactHistory& history, Real work, Real elastic) {
  events_.push_back(event_of(key, false, history, work, elastic));
}

double CollisionSpectra::dissipated() const { return dissipated_; }

double CollisionSpectra::total(Kind kind, Quantity quantity) const {
  double sum = 0;
  for (double e : histogram(kind, quantity).energy) sum += e;
  return sum;
}

double CollisionSpectra::dissipated_by_class(int c) const {
  double own = 0;
  for (Kind kind = 0; kind < kind_count(); ++kind) {
    const double d = dissipated(kind);
    const std::array<int, 2> classes = classes_of(kind);
    if (classes[0] == c) own += classes[1] == c || classes[1] < 0 ? d : 0.5 * d;
    else if (classes[1] == c) own += 0.5 * d;
  }
  return own;
}

double CollisionSpectra::dissipated_over_kinds() const {
  double all = 0;
  for (Kind kind = 0; kind < kind_count(); ++kind) all += dissipated(kind);
  return all;
}

double CollisionSpectra::dissipation_share(int c) const {
  const double all = dissipated_over_kinds();
  return all != 0 ? dissipated_by_class(c) / all : 0;
}

CollisionSpectra::Books CollisionSpectra::books() const {
  Books b;
  for (const Histogram& h : histogram_) {
    b.count.insert(b.count.end(), h.count.begin(), h.count.end());
    b.energy.insert(b.energy.end(), h.energy.begin(), h.energy.end());
  }
  b.events = events_;
  b.dissipated = dissipated_;
  return b;
}

bool CollisionSpectra::set_books(const Books& b) {
  const std::size_t cells = histogram_.size() * bin_count;
  if (b.events.size() != events_.size() || b.count.size() != cells || b.energy.size() != cells) return false;
  for (std::size_t h = 0; h < histogram_.size(); ++h) {
    std::copy_n(b.count.begin() + static_cast<std::ptrdiff_t>(h * bin_count), bin_count, histogram_[h].count.begin());
    std::copy_n(b.energy.begin() + static_cast<std::ptrdiff_t>(h * bin_count), bin_count, histogram_[h].energy.begin());
  }
  events_ = b.events;
  dissipated_ = b.dissipated;
  return true;
}

}  // namespace dem
