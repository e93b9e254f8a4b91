#pragma once
// What a run may ask of the controller on its command line, checked in one place: exo_controller refuses
// these values, and `exoid experiment` refuses them before it starts any process (a run whose controller
// refused to start would leave the sim open loop).
#include <string>

namespace exoid::controller {

inline constexpr long long kMinMoves = 1;     ///< --moves
inline constexpr long long kMaxMoves = 1000;  ///< --moves: 1000 moves is ~50 min simulated
inline constexpr long long kMinSeed = 0;      ///< --seed (the move sequence's RNG seed, unsigned 63 bits)
inline constexpr long long kMaxSeed = 9223372036854775807LL;

/// True if `moves` is a CoM move count the controller accepts; else *error: "--moves: expected an integer in
/// 1..1000, got <moves>".
bool checkMoves(long long moves, std::string* error);
/// True if `seed` is a move-sequence seed the controller accepts (0..2^63-1); else a one-line *error.
bool checkSeed(long long seed, std::string* error);

}  // namespace exoid::controller
