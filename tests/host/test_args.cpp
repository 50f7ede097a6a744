// The command lines' one number parser (auger/args.hpp): whole decimal texts only, and a
// comma-separated list of them for options such as a bench's --thresholds.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "auger/args.hpp"

using auger::Args;

namespace {
Args with(const std::string& key, const std::string& value) {
  Args a;
  a.options.push_back({key, value});
  return a;
}
}  // namespace

TEST_CASE("a number is the whole text in decimal: no hex, inf, nan, blanks or trailing text") {
  double x = 0;
  CHECK(auger::decimal_number("-2e-3", x));
  CHECK(x == -2e-3);
  for (const char* bad : {"", "0x1", "inf", "nan", " 1", "1 ", "1.5abc", "1e999"}) {
    INFO(bad);
    CHECK_FALSE(auger::decimal_number(bad, x));
  }
}

TEST_CASE("a list option: comma-separated numbers, a given count or at least one") {
  std::vector<double> v{7};
  CHECK(Args{}.numbers("t", "--l", 3, v));  // absent: untouched
  CHECK(v == std::vector<double>{7});
  CHECK(with("--l", "0.012,0.012,0.01").numbers("t", "--l", 3, v));
  CHECK(v == std::vector<double>{0.012, 0.012, 0.01});
  CHECK(with("--l", "16").numbers("t", "--l", 0, v));
  CHECK(v == std::vector<double>{16});
  for (const char* bad : {"1,2", "1,2,3,4", "1,,3", "1,2,3junk", "0x1,2,3", "1,2,", ""}) {
    INFO(bad);
    std::vector<double> w{7};
    CHECK_FALSE(with("--l", bad).numbers("t", "--l", 3, w));
    CHECK(w == std::vector<double>{7});  // a refused list changes nothing
  }
  CHECK_FALSE(with("--l", "8,abc").numbers("t", "--l", 0, v));
}
