#pragma once
// Strict number parsing shared by every reader of numbers from outside (URDF, MJCF, YAML, CSV, command line):
// the whole token must be one number, finite, and in the caller's range. Locale-independent (std::from_chars).
// A value too small for a double (1e-320, 1e-400) is accepted as its subnormal or zero rounding; one too large
// (1e400) is refused: the first is still the number written, the second is not.
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace exoid::common {

/// Parses `text` as one finite decimal floating-point number (optional sign, digits, '.', exponent). No
/// surrounding whitespace, no hex, no "nan"/"inf". On failure returns false and sets *why (if given) to a short
/// reason without the value (e.g. "not a number", "not finite", "too large for a double").
bool parseDouble(std::string_view text, double& out, std::string* why = nullptr);

/// parseDouble, then lo <= value <= hi; the reason names the range on failure.
bool parseDouble(std::string_view text, double lo, double hi, double& out, std::string* why = nullptr);

/// Parses `text` as one decimal integer (optional sign, digits only) within [lo, hi].
bool parseInt(std::string_view text, int64_t lo, int64_t hi, int64_t& out, std::string* why = nullptr);

/// Splits `text` at ASCII whitespace and parses every token with parseDouble. `count` >= 0 requires exactly
/// that many numbers. Returns false with *why naming the offending token.
bool parseDoubleList(std::string_view text, int count, std::vector<double>& out, std::string* why = nullptr);

/// "'value'" quoted for error messages, shortened to at most 40 characters and with control bytes shown as '?'.
std::string quoteValue(std::string_view value);

}  // namespace exoid::common
