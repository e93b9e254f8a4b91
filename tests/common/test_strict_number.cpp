// The shared strict number parser: whole token, finite, in range; subnormals accepted, overflow refused.
#include <gtest/gtest.h>

#include <cmath>

#include "exoid/common/strict_number.hpp"

namespace exoid::common {
namespace {

TEST(StrictNumber, AcceptsEveryDecimalSpelling) {
  const std::pair<const char*, double> ok[] = {
      {"0", 0.0},       {"-0", -0.0},       {"13.5", 13.5},       {"+2", 2.0},         {"-1e3", -1000.0},
      {".5", 0.5},      {"5.", 5.0},        {"1E-3", 1e-3},       {"1e308", 1e308},    {"-1.7976931348623157e308", -1.7976931348623157e308}};
  for (const auto& [text, value] : ok) {
    double v = 42.0;
    std::string why;
    EXPECT_TRUE(parseDouble(text, v, &why)) << text << ": " << why;
    EXPECT_EQ(v, value) << text;
  }
}

TEST(StrictNumber, SubnormalsAndUnderflowAreNumbers) {
  double v = 1.0;
  ASSERT_TRUE(parseDouble("1e-320", v));
  EXPECT_EQ(v, std::strtod("1e-320", nullptr));
  EXPECT_GT(v, 0.0);
  EXPECT_EQ(std::fpclassify(v), FP_SUBNORMAL);
  ASSERT_TRUE(parseDouble("4.9e-324", v));
  EXPECT_EQ(v, std::numeric_limits<double>::denorm_min());
  ASSERT_TRUE(parseDouble("-1e-400", v));  // below the smallest subnormal: rounds to (negative) zero
  EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(std::signbit(v));
}

TEST(StrictNumber, RefusesWhatIsNotOneFiniteNumber) {
  const std::pair<const char*, const char*> bad[] = {
      {"", "empty"},        {"13,5", "not a number"}, {"abc", "not a number"}, {"nan", "not finite"},
      {"-nan", "not finite"}, {"inf", "not finite"},    {"-Infinity", "not finite"}, {"1e400", "too large"},
      {"-1e400", "too large"}, {" 1", "not a number"},   {"1 ", "not a number"},   {"1.5x", "not a number"},
      {"0x10", "not a number"}, {"+-1", "not a number"}, {"++1", "not a number"}, {"1e", "not a number"},
      {"-", "not a number"},  {"+", "not a number"},    {"1..2", "not a number"}};
  for (const auto& [text, reason] : bad) {
    double v = 42.0;
    std::string why;
    EXPECT_FALSE(parseDouble(text, v, &why)) << text;
    EXPECT_NE(why.find(reason), std::string::npos) << text << ": " << why;
    EXPECT_EQ(v, 42.0) << "output untouched on failure: " << text;
  }
}

TEST(StrictNumber, Range) {
  double v = 0.0;
  std::string why;
  EXPECT_TRUE(parseDouble("0.5", 0.0, 1.0, v, &why));
  EXPECT_FALSE(parseDouble("1.5", 0.0, 1.0, v, &why));
  EXPECT_NE(why.find("in [0, 1]"), std::string::npos) << why;
  EXPECT_FALSE(parseDouble("-1", 0.0, std::numeric_limits<double>::max(), v, &why));
  EXPECT_NE(why.find(">= 0"), std::string::npos) << why;
}

TEST(StrictInteger, WholeDecimalTokenInRange) {
  int64_t v = 0;
  std::string why;
  EXPECT_TRUE(parseInt("010", 0, 100, v, &why));
  EXPECT_EQ(v, 10);  // decimal, never octal
  EXPECT_TRUE(parseInt("+7", 0, 100, v, &why));
  EXPECT_EQ(v, 7);
  EXPECT_TRUE(parseInt("-9223372036854775808", INT64_MIN, INT64_MAX, v, &why));
  EXPECT_EQ(v, INT64_MIN);
  for (const char* bad : {"", "1.5", "1e3", "0x10", " 1", "1 ", "abc", "--1", "+-1", "-", "99999999999999999999"}) {
    v = 5;
    EXPECT_FALSE(parseInt(bad, INT64_MIN, INT64_MAX, v, &why)) << bad;
    EXPECT_EQ(v, 5) << bad;
  }
  EXPECT_FALSE(parseInt("-1", 0, 10, v, &why));
  EXPECT_NE(why.find("in [0, 10]"), std::string::npos) << why;
  EXPECT_FALSE(parseInt("1001", 1, 1000, v, &why));
}

TEST(StrictNumber, Lists) {
  std::vector<double> v;
  std::string why;
  EXPECT_TRUE(parseDoubleList("  0 -1.5\t2e-3\n", 3, v, &why)) << why;
  EXPECT_EQ(v, (std::vector<double>{0.0, -1.5, 2e-3}));
  EXPECT_FALSE(parseDoubleList("0 1", 3, v, &why));
  EXPECT_NE(why.find("expected 3 numbers, got 2"), std::string::npos) << why;
  EXPECT_FALSE(parseDoubleList("0 nan 1", 3, v, &why));
  EXPECT_NE(why.find("number 2 'nan': not finite"), std::string::npos) << why;
  EXPECT_FALSE(parseDoubleList("0,1,2", 3, v, &why));
  EXPECT_TRUE(parseDoubleList("", -1, v, &why));
  EXPECT_TRUE(v.empty());
}

TEST(StrictNumber, QuoteValueIsShortAndPrintable) {
  EXPECT_EQ(quoteValue("a\nb"), "'a?b'");
  EXPECT_EQ(quoteValue(std::string(100, 'x')), "'" + std::string(40, 'x') + "...'");
}

}  // namespace
}  // namespace exoid::common
