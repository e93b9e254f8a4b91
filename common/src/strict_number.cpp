#include "exoid/common/strict_number.hpp"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <system_error>

namespace exoid::common {

namespace {
bool fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}
std::string rangeText(double lo, double hi) {
  char buf[96];
  if (lo == -std::numeric_limits<double>::infinity() || lo == std::numeric_limits<double>::lowest())
    std::snprintf(buf, sizeof buf, "<= %g", hi);
  else if (hi == std::numeric_limits<double>::infinity() || hi == std::numeric_limits<double>::max())
    std::snprintf(buf, sizeof buf, ">= %g", lo);
  else
    std::snprintf(buf, sizeof buf, "in [%g, %g]", lo, hi);
  return buf;
}
}  // namespace

bool parseDouble(std::string_view text, double& out, std::string* why) {
  if (text.empty()) return fail(why, "empty, expected a number");
  std::string_view body = text;
  if (body.front() == '+') body.remove_prefix(1);  // from_chars refuses a leading '+'
  if (body.empty() || (body.size() < text.size() && (body.front() == '-' || body.front() == '+')))
    return fail(why, "not a number");
  double v = 0.0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v, std::chars_format::general);
  if (r.ptr != body.data() + body.size() || r.ec == std::errc::invalid_argument) return fail(why, "not a number");
  if (r.ec == std::errc::result_out_of_range) {
    // from_chars reports both overflow and underflow; strtod tells them apart (underflow gives 0 or a subnormal).
    const std::string copy(body);
    const double s = std::strtod(copy.c_str(), nullptr);
    if (std::isinf(s)) return fail(why, "too large for a double");
    v = s;
  }
  if (!std::isfinite(v)) return fail(why, "not finite");
  out = v;
  return true;
}

bool parseDouble(std::string_view text, double lo, double hi, double& out, std::string* why) {
  double v = 0.0;
  if (!parseDouble(text, v, why)) return false;
  if (v < lo || v > hi) return fail(why, "out of range, expected " + rangeText(lo, hi));
  out = v;
  return true;
}

bool parseInt(std::string_view text, int64_t lo, int64_t hi, int64_t& out, std::string* why) {
  if (text.empty()) return fail(why, "empty, expected an integer");
  std::string_view body = text;
  if (body.front() == '+') body.remove_prefix(1);
  int64_t v = 0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v, 10);
  if (body.empty() || (body.size() < text.size() && (body.front() == '-' || body.front() == '+')))
    return fail(why, "not an integer");
  if (r.ec == std::errc::result_out_of_range) return fail(why, "integer too large");
  if (r.ec != std::errc() || r.ptr != body.data() + body.size()) return fail(why, "not an integer");
  if (v < lo || v > hi) {
    std::string range;
    if (lo == std::numeric_limits<int64_t>::min())
      range = "<= " + std::to_string(hi);
    else if (hi == std::numeric_limits<int64_t>::max())
      range = ">= " + std::to_string(lo);
    else
      range = "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return fail(why, "out of range, expected an integer " + range);
  }
  out = v;
  return true;
}

bool parseDoubleList(std::string_view text, int count, std::vector<double>& out, std::string* why) {
  out.clear();
  size_t i = 0;
  auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; };
  while (i < text.size()) {
    while (i < text.size() && space(text[i])) ++i;
    if (i == text.size()) break;
    size_t j = i;
    while (j < text.size() && !space(text[j])) ++j;
    double v = 0.0;
    std::string reason;
    if (!parseDouble(text.substr(i, j - i), v, &reason))
      return fail(why, "number " + std::to_string(out.size() + 1) + " " + quoteValue(text.substr(i, j - i)) + ": " + reason);
    out.push_back(v);
    i = j;
  }
  if (count >= 0 && static_cast<int>(out.size()) != count)
    return fail(why, "expected " + std::to_string(count) + " numbers, got " + std::to_string(out.size()));
  return true;
}

std::string quoteValue(std::string_view value) {
  constexpr size_t kMax = 40;
  std::string s = "'";
  for (size_t i = 0; i < value.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(value[i]);
    s += (c < 0x20 || c == 0x7f) ? '?' : static_cast<char>(c);
  }
  if (value.size() > kMax) s += "...";
  return s + "'";
}

}  // namespace exoid::common
