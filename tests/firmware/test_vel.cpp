// Velocity by position differencing: scale, rounding, wrap, clamping.
#include <catch2/catch.hpp>

#include <algorithm>
#include <climits>
#include <cmath>

#include "config.h"
#include "vel.h"

TEST_CASE("velocity: resolution at 48 counts x 369:1 (an estimated ratio) is about 0.34 rpm")
{
    vel_t v;
    vel_init(&v, COUNTS_PER_REV_X100, CONTROL_PERIOD_MS);
    CHECK(COUNTS_PER_REV_X100 == 1771200UL);
    // 6e8 / (1771200 * 10) = 33.8753 crpm per count per 10 ms, held in 16.16
    CHECK(v.crpm_per_count_q16 / 65536.0 == Approx(33.87534).epsilon(1e-6));
    CHECK(vel_crpm_from_counts(&v, 0) == 0);
    CHECK(vel_crpm_from_counts(&v, 1) == 34);
    CHECK(vel_crpm_from_counts(&v, -1) == -34);
    CHECK(vel_crpm_from_counts(&v, 10) == 339);   // 338.75
    CHECK(vel_crpm_from_counts(&v, -10) == -339);
    // 23 rpm (no-load at 12 V) is 67.9 counts per period
    CHECK(vel_crpm_from_counts(&v, 68) == 2304);  // 2303.5 rounds away from zero
}

TEST_CASE("velocity: a speed worked by hand")
{
    vel_t v;
    vel_init(&v, 480000, 10); // 4800 counts per revolution
    // 12 counts per 10 ms = 1200 counts/s = 0.25 rev/s = 15 rpm
    CHECK(vel_crpm_from_counts(&v, 12) == 1500);
    vel_init(&v, 480000, 20); // same counts over 20 ms: half the speed
    CHECK(vel_crpm_from_counts(&v, 12) == 750);
}

TEST_CASE("velocity: differences from positions, first sample gives 0")
{
    vel_t v;
    vel_init(&v, COUNTS_PER_REV_X100, CONTROL_PERIOD_MS);
    CHECK(vel_diff_counts(&v, 1000) == 0);
    CHECK(vel_diff_counts(&v, 1010) == 10);
    CHECK(vel_diff_counts(&v, 1000) == -10);
    CHECK(vel_update_crpm(&v, 1010) == 339);
    vel_restart(&v);
    CHECK(vel_diff_counts(&v, 50000) == 0);
}

TEST_CASE("velocity: the 32-bit position wraps")
{
    vel_t v;
    vel_init(&v, COUNTS_PER_REV_X100, CONTROL_PERIOD_MS);
    vel_diff_counts(&v, INT32_MAX - 5);
    CHECK(vel_diff_counts(&v, INT32_MIN + 4) == 10);
    CHECK(vel_diff_counts(&v, INT32_MAX - 5) == -10);
}

TEST_CASE("velocity: clamped to the int16 telemetry range")
{
    vel_t v;
    vel_init(&v, 4800, 10); // 12500 crpm per count
    CHECK(vel_crpm_from_counts(&v, 2) == 25000);
    CHECK(vel_crpm_from_counts(&v, 3) == 32767);
    CHECK(vel_crpm_from_counts(&v, -3) == -32767);
    CHECK(vel_crpm_from_counts(&v, INT32_MAX) == 32767);
    CHECK(vel_crpm_from_counts(&v, INT32_MIN) == -32767);
}

TEST_CASE("velocity: fixed point equals the exactly rounded speed")
{
    // crpm = counts x 6e8 / (cpr_x100 x period), rounded half away from zero. The 16.16
    // factor is within 2^-17 of the exact one, so the result can differ only where the
    // exact value lies within counts x 2^-17 of a half, and then by one.
    for (uint32_t cpr : {1771200u, 905328u, 480000u, 100000u, 12345678u}) {
        vel_t v;
        vel_init(&v, cpr, CONTROL_PERIOD_MS);
        int off = 0;
        for (int32_t c = -5000; c <= 5000; ++c) {
            const double exact = double(c) * 6e8 / (double(cpr) * CONTROL_PERIOD_MS);
            const double clamped = std::max(-32767.0, std::min(32767.0, std::round(exact)));
            const int16_t got = vel_crpm_from_counts(&v, c);
            if (got != int16_t(clamped)) {
                ++off;
                const double frac = std::fabs(exact - std::trunc(exact));
                INFO("cpr " << cpr << " counts " << c << " exact " << exact << " got " << got);
                CHECK(std::fabs(frac - 0.5) < std::abs(c) / 131072.0);
                CHECK(std::abs(got - clamped) == 1);
            }
        }
        CHECK(off < 100);  // of 10001
    }
}
