// Current foldback: linear derating between the start level and the overcurrent trip, the
// limit's fall and rise, and the sampled loop it closes with a locked rotor (foldback.h).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "foldback.h"
#include "pid.h"

namespace {
double lim(const foldback_t& f) { return double(f.limit_q27) / double(PID_U_ONE); }
}  // namespace

TEST_CASE("foldback: off, below the start, at the trip")
{
    foldback_t f;
    foldback_configure(&f, 0, 5200);  // off
    for (int16_t ma : {0, 4000, 5200, 9000, -9000}) CHECK(foldback_update(&f, ma, PID_U_ONE) == PID_U_ONE);
    CHECK_FALSE(foldback_active(&f));

    foldback_configure(&f, 4500, 5200);
    CHECK(foldback_update(&f, 4500, PID_U_ONE) == PID_U_ONE);  // at the start level: full output
    CHECK_FALSE(foldback_active(&f));
    CHECK(foldback_update(&f, 5200, PID_U_ONE) == PID_U_ONE / 2);  // at the trip: half, at once
    CHECK(foldback_active(&f));
    // The next reading still shows the period before the halving (the INA219 averages the
    // last 8.5 ms): held, not halved again ...
    CHECK(foldback_update(&f, -6000, PID_U_ONE / 2) == PID_U_ONE / 2);
    // ... but a third one in a row halves again (either sign).
    CHECK(foldback_update(&f, -6000, PID_U_ONE / 2) == PID_U_ONE / 4);
}

TEST_CASE("foldback: towards the linear derating in bounded steps; faster below the band")
{
    foldback_t f;
    foldback_configure(&f, 4500, 5200);
    CHECK(lim(f) == 1.0);
    // Inside the band the target is (trip - I) / (trip - start), 0.5 at 4850 mA; the limit
    // falls towards it by at most 1/16 a period ...
    foldback_update(&f, 4850, PID_U_ONE);
    CHECK(lim(f) == Approx(1.0 - 1.0 / 16).margin(1e-6));
    for (int i = 0; i < 40; ++i) foldback_update(&f, 4850, PID_U_ONE);
    CHECK(lim(f) == Approx(0.5).margin(1e-4));  // and stops there
    // ... and rises towards a higher target by at most 1/256 ...
    foldback_update(&f, 4600, PID_U_ONE);
    CHECK(lim(f) == Approx(0.5 + 1.0 / 256).margin(1e-4));
    // ... and by 1/64 below the band, up to full output.
    foldback_update(&f, 1000, PID_U_ONE);
    CHECK(lim(f) == Approx(0.5 + 1.0 / 256 + 1.0 / 64).margin(1e-4));
    int periods = 0;
    while (foldback_active(&f) && periods < 1000) {
        foldback_update(&f, 1000, PID_U_ONE);
        ++periods;
    }
    CHECK(lim(f) == 1.0);
    CHECK(periods <= 32);  // 0.48 of output at 1/64 a period
    foldback_reset(&f);
    CHECK_FALSE(foldback_active(&f));
    // Over the start level it acts from the output as it is (here 0.6 of the rating, either
    // sign), not from full output.
    foldback_update(&f, 5000, -PID_U_ONE * 6 / 10);
    CHECK(lim(f) == Approx(0.6 - 1.0 / 16).margin(1e-4));
    // Below the start level the output does not pull it down (a step may need full output).
    foldback_reset(&f);
    foldback_update(&f, 3000, PID_U_ONE / 10);
    CHECK(lim(f) == 1.0);
}

TEST_CASE("foldback: a locked rotor settles below the trip, from any battery voltage")
{
    // The plant the header's comment describes: a locked rotor, the PID at its limit, the
    // pack current the INA219 reads one period later = duty x motor current =
    // (u 12 V / Vbatt) x (u 12 V / R), R = 0.6 ohm (sim/motor_model.c's defaults).
    for (double vbatt : {15.0, 18.0, 21.0}) {
        foldback_t f;
        foldback_configure(&f, 4500, 5200);
        double reading_a = 0, peak_late_a = 0, u = 1.0;
        int above_trip = 0;
        for (int k = 0; k < 300; ++k) {
            foldback_update(&f, int16_t(std::lround(reading_a * 1000)), f.limit_q27);
            u = lim(f);  // the PID wants more: it sits at the limit
            const double pack_a = (u * 12.0 / vbatt) * (u * 12.0 / 0.6);
            reading_a = pack_a;
            if (k > 5) {
                peak_late_a = std::max(peak_late_a, pack_a);
                above_trip += pack_a >= 5.2;
            }
        }
        INFO(vbatt << " V: peak pack current after the first 50 ms " << peak_late_a << " A, final u " << u);
        CHECK(above_trip == 0);
        CHECK(peak_late_a < 5.2);
        CHECK(peak_late_a > 4.5);  // and it still drives: the derating is what holds it
        CHECK(foldback_active(&f));
    }
}
