#pragma once
// What a run may ask of the controller on its command line, in one place: exo_controller's --moves/--seed
// and `exoid experiment`'s are both checked against these limits (common::strictInteger), so exoid refuses
// what the controller would, before it starts any process (a run whose controller refused to start left
// the sim running open loop for minutes and wrote gigabytes of log).
namespace exoid::controller {

inline constexpr long long kMaxMoves = 1000;  ///< --moves 1..1000 (0: the configuration's); 1000 moves ~50 min
inline constexpr long long kMinSeed = 0;      ///< --seed: the move sequence's RNG seed, 0..2^63-1
inline constexpr long long kMaxSeed = 9223372036854775807LL;

}  // namespace exoid::controller
