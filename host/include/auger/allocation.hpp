// Force allocation, eq. (22): screw speeds (rpm) for a body force. Two allocators, selectable:
// - pseudo_inverse: omega = (S B)^+ tau (the paper), scaled down uniformly if a screw saturates;
// - null_space: the same plus lambda n, n along [-1, 1, -1, 1] (S B n = 0, so the nominal force
//   is unchanged), which keeps every screw above omega_min_rpm when feasible (the paper's stuck
//   diagonal on sand), and respects saturation with an explicit priority between yaw and
//   translation. Order of precedence: the priority part of tau, then every screw at least
//   omega_min_rpm, then as much of the other part as still fits.
#pragma once

#include "auger/model.hpp"

namespace auger {

enum class AllocatorKind { pseudo_inverse, null_space };
enum class AllocationPriority { yaw, translation };  // which part of tau is kept whole first

struct AllocatorConfig {
  AllocatorKind kind = AllocatorKind::null_space;
  AllocationPriority priority = AllocationPriority::yaw;
  double omega_max_rpm = 23.0;  // saturation (motor rating)
  double omega_min_rpm = 3.0;   // keep every screw at least this fast ...
  double engage_rpm = 3.0;      // ... when the base allocation asks this much of some screw
  // A screw keeps last cycle's direction unless reversing it saves more than this on every screw
  // (0: off, the smallest |lambda| every cycle; docs/model.md says why it is off by default).
  double sign_hold_rpm = 0.0;
};

struct AllocationResult {
  Vec4 omega_rpm = Vec4::Zero();
  double lambda = 0;             // null-space coefficient (along the unit vector model.null_space)
  double scale_primary = 1;      // share of the priority part of tau delivered
  double scale_secondary = 1;    // share of the other part delivered
  bool min_speed_met = true;     // every screw at least omega_min_rpm (when engaged)
};

// Interval of null-space coefficients keeping base + lambda n within +-omega_max; false if empty.
bool feasible_lambda_interval(const Vec4& base_rpm, const Vec4& n, double omega_max_rpm, double& lo,
                              double& hi);

// eq. (22) with the configured allocator. `out` carries last cycle's speeds in (a fresh result:
// none): the null-space allocator keeps a screw's direction from them (sign_hold_rpm). No
// allocation on the heap.
void allocate(const Model& model, const AllocatorConfig& config, const Vec3& tau_n, AllocationResult& out);

}  // namespace auger
