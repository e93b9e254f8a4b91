#pragma once
// Error messages are one line (docs/conventions.md), also when they quote untrusted input (a YAML key, a
// joint name from a message, a parser's own text): control characters are written as escapes.
#include <cstdio>
#include <string>

namespace exoid {

/// `text` with every control character written as an escape: \n, \r, \t, other bytes below 0x20 and
/// 0x7f as \xNN. Printable and non-ASCII (UTF-8) bytes are kept.
inline std::string oneLine(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else {
      out += ch;
    }
  }
  return out;
}

}  // namespace exoid
