#include "vims_common/option_table.h"

#include <charconv>
#include <cmath>
#include <limits>

namespace vims {

Bounds Bounds::any() {
  return Bounds(-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), false);
}
Bounds Bounds::positive() { return Bounds(0.0, std::numeric_limits<double>::infinity(), true); }
Bounds Bounds::nonNegative() { return Bounds(0.0, std::numeric_limits<double>::infinity(), false); }
Bounds Bounds::closed(double lo, double hi) { return Bounds(lo, hi, false); }

std::string Bounds::violation(double value) const {
  const bool inside = std::isfinite(value) && (lo_open_ ? value > lo_ : value >= lo_) && value <= hi_;
  if (inside) return "";
  const std::string got = ", got " + formatOptionNumber(value);
  if (std::isinf(lo_) && std::isinf(hi_)) return "must be a finite number" + got;
  return std::string("must be ") + (std::isinf(hi_) ? "" : "in ") + describe() + got;
}

std::string Bounds::describe() const {
  if (std::isinf(hi_)) {
    if (std::isinf(lo_)) return "any";
    return std::string(lo_open_ ? "> " : ">= ") + formatOptionNumber(lo_);
  }
  return "[" + formatOptionNumber(lo_) + ", " + formatOptionNumber(hi_) + "]";
}

std::string formatOptionNumber(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string quoteYaml(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string indentYaml(const std::string& block, const std::string& prefix) {
  std::istringstream in(block);
  std::string line;
  std::string out;
  while (std::getline(in, line)) out += prefix + line + "\n";
  return out;
}

}  // namespace vims
