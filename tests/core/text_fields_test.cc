#include "core/text_fields.h"

#include <cmath>
#include <cstdlib>
#include <random>
#include <string>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

using text_fields::ParseDouble;
using text_fields::ParseFiniteDouble;

double Strtod(const std::string& s) { return std::strtod(s.c_str(), nullptr); }

// The fast path (std::from_chars) gives strtod's double bit for bit: seeded random numbers
// written as a CARMEN log writes them (fixed, scientific, shortest round-trip) and the
// hand-picked corners of decimal-to-binary rounding.
TEST(TextFieldsTest, ParseDoubleGivesStrtodsDouble) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> magnitude(-12.0, 12.0);
  std::uniform_int_distribution<int> digits(1, 17);
  char text[64];
  for (int i = 0; i < 20000; ++i) {
    const double v = (rng() & 1 ? -1.0 : 1.0) * std::pow(10.0, magnitude(rng));
    const int precision = digits(rng);
    for (const char* format : {"%.*f", "%.*e", "%.*g"}) {
      std::snprintf(text, sizeof(text), format, precision, v);
      double parsed = 0.0;
      ASSERT_TRUE(ParseDouble(text, &parsed)) << text;
      ASSERT_EQ(parsed, Strtod(text)) << text;
    }
  }
  // ... including the plain decimals' fast path and the edges where it hands over to from_chars
  // (m beyond 2^53, more than 19 digits).
  for (const char* text : {"0", "-0", "-0.000", "0.1", "81.91", "00012.5000", "1e-320", "2.2250738585072011e-308",
                           "9007199254740992", "9007199254740993", "900719925474099.3", "0.9007199254740993",
                           "1234567890123456789", "12345678901234567890.5", "0.000000000000000001", "0.0000000000000000001",
                           "1.7976931348623157e308", "4.9406564584124654e-324"}) {
    double parsed = 0.0;
    ASSERT_TRUE(ParseDouble(text, &parsed)) << text;
    EXPECT_EQ(parsed, Strtod(text)) << text;
    EXPECT_EQ(std::signbit(parsed), std::signbit(Strtod(text))) << text;
  }
}

// What from_chars refuses but strtod takes still parses as before; garbage is still refused.
TEST(TextFieldsTest, ParseDoubleKeepsStrtodsSyntax) {
  double v = 0.0;
  ASSERT_TRUE(ParseDouble("+1.5", &v));
  EXPECT_EQ(v, 1.5);
  ASSERT_TRUE(ParseDouble("0x1p-2", &v));
  EXPECT_EQ(v, 0.25);
  ASSERT_TRUE(ParseDouble("1e999", &v));  // overflow: infinite, refused by the finite parse
  EXPECT_TRUE(std::isinf(v));
  EXPECT_FALSE(ParseFiniteDouble("1e999", &v));
  ASSERT_TRUE(ParseDouble("nan", &v));
  EXPECT_TRUE(std::isnan(v));
  EXPECT_FALSE(ParseFiniteDouble("nan", &v));
  v = 7.0;
  ASSERT_TRUE(ParseDouble("1.", &v));  // strtod's syntax, from_chars' too: not the fast path's
  EXPECT_EQ(v, 1.0);
  ASSERT_TRUE(ParseDouble(".5", &v));
  EXPECT_EQ(v, 0.5);
  ASSERT_TRUE(ParseDouble("-.5", &v));
  EXPECT_EQ(v, -0.5);
  v = 7.0;
  for (const char* bad : {"", "1.5x", "x", "1.5 ", "--1", "1e", ".", "-", "1..5", "1.5.", "- 1"}) {
    EXPECT_FALSE(ParseDouble(bad, &v)) << "'" << bad << "'";
  }
  EXPECT_EQ(v, 7.0);  // untouched by a refusal
}

}  // namespace
}  // namespace hetslam
