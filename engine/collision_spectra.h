#pragma once
// Collision energy spectra (docs/physics.md 7.4): per contact event (a contact from its start to its end)
// the impact energy m* v_n^2 / 2 at its start and the energy its normal spring-dashpot and its
// tangential and rolling parts dissipated, binned logarithmically, particle-particle ("ball-ball")
// and particle-wall ("ball-liner") apart. An event is booked when its contact ends; contacts still
// open are not events yet (live_* below gives what they have dissipated so far).
#include <array>
#include <cstdint>
#include <vector>

#include "engine/contacts.h"

namespace dem {

class ContactEvents;

class CollisionSpectra {
 public:
  enum Kind { ball_ball, ball_wall, kind_count };
  enum Quantity { impact, normal_dissipated, tangential_dissipated, quantity_count };
  static constexpr const char* kind_names[kind_count] = {"ball-ball", "ball-liner"};
  static constexpr const char* quantity_names[quantity_count] = {"impact_energy", "normal_dissipated",
                                                                 "tangential_dissipated"};
  // Bins: bins_per_decade per decade from lowest_energy up; above goes to the last bin (written with
  // an upper edge of inf), below (zero and the odd slightly negative split included) to the first
  // (written with a lower edge of 0).
  static constexpr int bins_per_decade = 5;
  static constexpr int bin_count = 5 * 18;
  static constexpr double lowest_energy = 1e-15;  // [J]

  /// Books the contacts of `before` that `after` no longer holds (both sorted by key).
  void record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key);
  void record_ended(const WallContacts& before, const WallContacts& after);

  /// Books one ended contact (its history, work and elastic energy at its last evaluation).
  void record(Kind kind, const ContactHistory& history, Real work, Real elastic);
  /// Books the events of a log, in its order.
  void record(const ContactEvents& events);
  /// Adds another's booked events, bin by bin.
  void add(const CollisionSpectra& other);

  /// Total energy the booked events dissipated (normal and tangential) [J].
  double dissipated() const;
  std::uint64_t events(Kind kind) const { return events_[kind]; }
  /// Sum of one quantity over the booked events of one kind [J].
  double total(Kind kind, Quantity quantity) const;
  /// Sum of one quantity over the booked events of one kind that fell in bin b [J].
  double energy(Kind kind, Quantity quantity, int b) const { return histogram_[kind][quantity].energy[b]; }

  /// Number of booked events of one kind whose quantity fell in bin b.
  std::uint64_t count(Kind kind, Quantity quantity, int b) const { return histogram_[kind][quantity].count[b]; }

  /// Lower edge of bin b [J].
  static double bin_low(int b);

 private:
  static int bin_of(double energy);
  void record_event(Kind kind, const double (&value)[quantity_count]);

  struct Histogram {
    std::array<std::uint64_t, bin_count> count{};
    std::array<double, bin_count> energy{};
  };
  std::array<std::array<Histogram, quantity_count>, kind_count> histogram_{};
  std::array<std::uint64_t, kind_count> events_{};
  double dissipated_ = 0;
};

/// Contact events kept in order until they can be booked: step doubling's islands log the contacts
/// that end in their trial steps, and only the accepted trial's log reaches the World's spectra (in
/// island order), so a rejected step or a redone round books nothing.
class ContactEvents {
 public:
  struct Event {
    CollisionSpectra::Kind kind;
    double value[CollisionSpectra::quantity_count];  // [J], as CollisionSpectra::record bins them
  };
  /// The same ended contacts as CollisionSpectra::record_ended finds, logged instead of booked.
  void record_ended(const PairContacts& before, const std::vector<std::uint64_t>& after_key);
  void record_ended(const WallContacts& before, const WallContacts& after);
  void clear() { events_.clear(); }
  const std::vector<Event>& events() const { return events_; }

 private:
  std::vector<Event> events_;
};

}  // namespace dem
