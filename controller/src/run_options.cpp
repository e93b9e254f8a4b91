#include "exoid/controller/run_options.hpp"

namespace exoid::controller {

bool checkMoves(long long moves, std::string* error) {
  if (moves >= kMinMoves && moves <= kMaxMoves) return true;
  if (error)
    *error = "--moves: expected an integer in " + std::to_string(kMinMoves) + ".." + std::to_string(kMaxMoves) +
             ", got " + std::to_string(moves);
  return false;
}

bool checkSeed(long long seed, std::string* error) {
  if (seed >= kMinSeed && seed <= kMaxSeed) return true;
  if (error) *error = "--seed: expected an unsigned integer (0.." + std::to_string(kMaxSeed) + "), got " + std::to_string(seed);
  return false;
}

}  // namespace exoid::controller
