// Small helpers shared by the text-file readers of core/ (CARMEN logs, trajectories,
// relations): split a line into white-space separated fields and parse one field as a
// number, insisting that the whole field is consumed. Not a public API of hetslam.
#ifndef HETSLAM_CORE_TEXT_FIELDS_H_
#define HETSLAM_CORE_TEXT_FIELDS_H_

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>
#include <system_error>
#include <vector>

namespace hetslam {
namespace text_fields {

// Splits on spaces, tabs, '\r' (CRLF files) and other white space; no empty fields.
inline void Split(const std::string& line, std::vector<std::string>* fields) {
  fields->clear();
  size_t i = 0;
  const size_t n = line.size();
  auto is_space = [](char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
  };
  while (i < n) {
    while (i < n && is_space(line[i])) ++i;
    if (i >= n) break;
    const size_t start = i;
    while (i < n && !is_space(line[i])) ++i;
    fields->emplace_back(line, start, i - start);
  }
}

// Clinger's fast path: [begin, end) a plain decimal ('-'? digits, then '.' and digits or
// nothing) of at most 19 digits whose digits as an integer m are at most 2^53: m and 10^k (k
// fraction digits, at most 19) are doubles exactly, so m / 10^k, one correctly rounded
// division, is the decimal correctly rounded, the double strtod gives. False (nothing written)
// otherwise. A CARMEN log's ranges and poses are such decimals (FR079: 1.7 million of them;
// from_chars took ~350 instructions each).
inline bool ParsePlainDecimal(const char* begin, const char* end, double* value) {
  static constexpr double kPowersOfTen[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,
                                            1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19};
  const char* p = begin;
  const bool negative = p < end && *p == '-';
  if (negative) ++p;
  unsigned long long m = 0;
  int digits = 0;
  auto read_digits = [&]() {
    const char* first = p;
    for (; p < end && static_cast<unsigned>(*p - '0') < 10u; ++p) {
      if (++digits > 19) return -1;  // m would overflow: not this path
      m = m * 10 + static_cast<unsigned>(*p - '0');
    }
    return static_cast<int>(p - first);
  };
  if (read_digits() <= 0) return false;
  int fraction = 0;
  if (p < end && *p == '.') {
    ++p;
    fraction = read_digits();
    if (fraction <= 0) return false;
  }
  if (p != end || m > (1ull << 53)) return false;
  const double magnitude = static_cast<double>(m) / kPowersOfTen[fraction];
  *value = negative ? -magnitude : magnitude;
  return true;
}

// True when the whole of `field` is a number (strtod syntax). NaN and infinities are
// accepted here; callers that need a finite number use ParseFiniteDouble.
inline bool ParseDouble(const std::string& field, double* value) {
  if (field.empty()) return false;
  if (ParsePlainDecimal(field.data(), field.data() + field.size(), value)) return true;
  // std::from_chars first (libstdc++ 12: 4-5x faster than strtod, tests/bench/io_bench.cc;
  // FR079's reading 0.39 -> 0.22 s), correctly rounded as strtod is, so the same double. What
  // it refuses and strtod takes (a leading '+', hexadecimal, out of range) goes to strtod.
  const char* const last = field.data() + field.size();
  double parsed = 0.0;
  const std::from_chars_result fast = std::from_chars(field.data(), last, parsed);
  if (fast.ec == std::errc() && fast.ptr == last) {
    *value = parsed;
    return true;
  }
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin + field.size()) return false;
  // ERANGE on overflow gives +-HUGE_VAL, rejected by the finiteness checks of callers;
  // ERANGE on underflow gives a tiny finite value, which is fine.
  *value = v;
  return true;
}

inline bool ParseFiniteDouble(const std::string& field, double* value) {
  double v = 0.0;
  if (!ParseDouble(field, &v) || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

// A decimal integer (optional sign), whole field consumed, within [min_value, max_value].
// `*value` receives the parsed number (clamped to long long) even when it is out of range,
// so that callers can report it.
inline bool ParseInteger(const std::string& field, long long min_value, long long max_value,
                         long long* value) {
  if (field.empty()) return false;
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (end != begin + field.size()) return false;
  *value = v;
  if (errno == ERANGE) return false;
  return v >= min_value && v <= max_value;
}

}  // namespace text_fields
}  // namespace hetslam

#endif  // HETSLAM_CORE_TEXT_FIELDS_H_
