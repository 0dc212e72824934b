#pragma once
// Collision energy spectra (docs/physics.md 7.4): per contact event (a contact from its start to its end)
// the impact energy m* v_n^2 / 2 at its start and the energy its normal spring-dashpot and its
// tangential and rolling parts dissipated, binned logarithmically per kind. A kind is a pair of size
// classes (particle-particle) or a size class and the walls ("liner"); one class (no size edges) has
// the two kinds ball-ball and ball-liner. An event is booked when its contact ends; contacts still
// open are not events yet (live_* below gives what they have dissipated so far).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/contacts.h"

namespace dem {

class ContactEvents;

class CollisionSpectra {
 public:
  using Kind = int;
  // The kinds of a spectrum with one size class.
  static constexpr Kind ball_ball = 0, ball_wall = 1;
  enum Quantity { impact, normal_dissipated, tangential_dissipated, quantity_count };
  static constexpr const char* quantity_names[quantity_count] = {"impact_energy", "normal_dissipated",
                                                                 "tangential_dissipated"};
  // Bins: bins_per_decade per decade from lowest_energy up; above goes to the last bin (written with
  // an upper edge of inf), below (zero and the odd slightly negative split included) to the first
  // (written with a lower edge of 0).
  static constexpr int bins_per_decade = 5;
  static constexpr int bin_count = 5 * 18;
  static constexpr double lowest_energy = 1e-15;  // [J]
  static constexpr int max_classes = 16;

  /// One size class without edges; `edges` [m] ascending: class c holds radii in [edges[c-1], edges[c]).
  explicit CollisionSpectra(std::vector<double> edges = {});

  /// Puts particle `id` in the class of its radius (every particle an event may name must be classified;
  /// unclassified ids count as class 0).
  void classify(ParticleId id, Real radius);
  int class_count() const { return static_cast<int>(edges_.size()) + 1; }
  const std::vector<double>& edges() const { return edges_; }
  int class_of_radius(Real radius) const;
  int class_of(ParticleId id) const { return id < class_of_id_.size() ? class_of_id_[id] : 0; }
  /// Kinds: the pairs a <= b of classes first (a-major), then class and wall.
  int kind_count() const { return class_count() * (class_count() + 1) / 2 + class_count(); }
  Kind pair_kind(int a, int b) const;
  Kind wall_kind(int c) const { return class_count() * (class_count() + 1) / 2 + c; }
  Kind kind_of_pair_key(std::uint64_t key) const {
    return pair_kind(class_of(static_cast<ParticleId>(key >> 32)), class_of(static_cast<ParticleId>(key)));
  }
  Kind kind_of_wall_key(std::uint64_t key) const { return wall_kind(class_of(static_cast<ParticleId>(key >> 32))); }
  /// The classes a kind involves (b = -1: the walls).
  std::array<int, 2> classes_of(Kind kind) const;
  /// "ball-ball", "ball-liner" with one class; else "c0-c1", "c1-liner", ... (class c: c<index>).
  std::string kind_name(Kind kind) const;
  /// "c<index>" (one class: "ball").
  std::string class_name(int c) const;

  /// Books the contacts of `before` that `after` no longer holds (both sorted by key).
  void record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key);
  void record_ended(const WallContacts& before, const WallContacts& after);

  /// Books one ended contact of the kind its key names (history, work and elastic energy at its last evaluation).
  void record_pair(std::uint64_t key, const ContactHistory& history, Real work, Real elastic);
  void record_wall(std::uint64_t key, const ContactHistory& history, Real work, Real elastic);
  /// Books the events of a log, in its order.
  void record(const ContactEvents& events);

  /// Total energy the booked events dissipated (normal and tangential) [J].
  double dissipated() const;
  std::uint64_t events(Kind kind) const { return events_[static_cast<std::size_t>(kind)]; }
  /// Sum of one quantity over the booked events of one kind [J].
  double total(Kind kind, Quantity quantity) const;
  /// Energy the booked events of one kind dissipated (normal and tangential) [J].
  double dissipated(Kind kind) const { return total(kind, normal_dissipated) + total(kind, tangential_dissipated); }
  /// What falls to class c of dissipated(): its own kinds whole, a mixed pair kind half to each
  /// class [J].
  double dissipated_by_class(int c) const;
  /// dissipated(kind) summed over the kinds: dissipated() summed bin by bin [J].
  double dissipated_over_kinds() const;
  /// Class c's share of dissipated(): dissipated_by_class(c) over dissipated_over_kinds(); the shares
  /// add up to 1 (0 without dissipation).
  double dissipation_share(int c) const;
  /// Sum of one quantity over the booked events of one kind that fell in bin b [J].
  double energy(Kind kind, Quantity quantity, int b) const { return histogram(kind, quantity).energy[b]; }

  /// Number of booked events of one kind whose quantity fell in bin b.
  std::uint64_t count(Kind kind, Quantity quantity, int b) const { return histogram(kind, quantity).count[b]; }

  /// Lower edge of bin b [J].
  static double bin_low(int b);

  /// The booked events as flat arrays (checkpoints): per kind and quantity, bin counts and energies;
  /// events per kind; the dissipated total.
  struct Books {
    std::vector<std::uint64_t> count;
    std::vector<double> energy;
    std::vector<std::uint64_t> events;
    double dissipated = 0;
  };
  Books books() const;
  /// False (and nothing changed) when the books have another kind count.
  bool set_books(const Books& books);

 private:
  struct Histogram {
    std::array<std::uint64_t, bin_count> count{};
    std::array<double, bin_count> energy{};
  };
  static int bin_of(double energy);
  void record_event(Kind kind, const double (&value)[quantity_count]);
  const Histogram& histogram(Kind kind, Quantity q) const {
    return histogram_[static_cast<std::size_t>(kind) * quantity_count + q];
  }

  std::vector<double> edges_;
  std::vector<std::uint8_t> class_of_id_;
  std::vector<Histogram> histogram_;  // kind-major, then quantity
  std::vector<std::uint64_t> events_;
  double dissipated_ = 0;
};

/// Contact events kept in order until they can be booked: step doubling's islands (and their
/// per-particle-level trials) log the contacts that end in their trial steps, and only the accepted
/// trial's log reaches the World's spectra (in island order), so a rejected step or a redone round
/// books nothing. An event carries its contact's key: the World's spectra find its kind from it.
class ContactEvents {
 public:
  struct Event {
    std::uint64_t key;  // pair_key or wall_key
    bool wall;
    double value[CollisionSpectra::quantity_count];  // [J], as CollisionSpectra books them
  };
  /// The same ended contacts as CollisionSpectra::record_ended finds, logged instead of booked.
  void record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key);
  void record_ended(const WallContacts& before, const WallContacts& after);
  void record_pair(std::uint64_t key, const ContactHistory& history, Real work, Real elastic);
  void add(const Event& event) { events_.push_back(event); }
  void append(const ContactEvents& other) { events_.insert(events_.end(), other.events_.begin(), other.events_.end()); }
  void clear() { events_.clear(); }
  const std::vector<Event>& events() const { return events_; }

 private:
  std::vector<Event> events_;
};

}  // namespace dem
