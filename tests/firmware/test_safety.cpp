// Safety state machine: boot state, command timeout, latching, clearing, overcurrent,
// under-voltage hysteresis, sensor and watchdog faults.
#include <catch2/catch.hpp>

#include "config.h"
#include "pid.h"
#include "safety.h"
#include "settings.h"

namespace {
safety_t booted(bool watchdog = false)
{
    proto_config_t cfg;
    settings_defaults(&cfg);
    safety_t s;
    safety_init(&s, &cfg, watchdog);
    return s;
}
const uint8_t EN = PROTO_SP_ENABLE;
const uint8_t CLR = PROTO_SP_CLEAR_FAULTS;
} // namespace

TEST_CASE("safety: boots disabled with no fault")
{
    safety_t s = booted();
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK(safety_status(&s) == 0);
    for (uint32_t t = 0; t < 1000; ++t) safety_tick(&s, t);
    CHECK(safety_status(&s) == 0); // no setpoint ever: no timeout fault either
}

TEST_CASE("safety: ms to the timeout is when safety_tick detects it")
{
    safety_t s = booted();
    CHECK(safety_ms_to_timeout(&s, 500) == UINT32_MAX); // no setpoint: no deadline
    CHECK(safety_on_setpoint(&s, EN, 1000));
    for (uint32_t t = 1000; t < 1400; ++t) {
        uint32_t due = safety_ms_to_timeout(&s, t);
        bool before = safety_motor_enabled(&s);
        uint32_t left = safety_tick(&s, t);
        CHECK(left == safety_ms_to_timeout(&s, t)); // what the main loop sleeps by
        // detected at t exactly when the deadline is t itself
        CHECK((before && !safety_motor_enabled(&s)) == (before && due == 0));
        if (t < 1250) CHECK(due == 1250 - t);
    }
    CHECK(safety_ms_to_timeout(&s, 1400) == UINT32_MAX); // timed out: no longer fresh
}

TEST_CASE("safety: command timeout at 250 ms exactly, latched")
{
    safety_t s = booted();
    CHECK(safety_on_setpoint(&s, EN, 1000));
    CHECK(safety_motor_enabled(&s));
    CHECK(safety_status(&s) == (PROTO_ST_ENABLED | PROTO_ST_SETPOINT_OK));
    for (uint32_t t = 1000; t <= 1249; ++t) safety_tick(&s, t);
    CHECK(safety_motor_enabled(&s));
    safety_tick(&s, 1250);
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK(safety_status(&s) == PROTO_F_CMD_TIMEOUT);

    // A new enabling setpoint alone does not restart the motor...
    CHECK_FALSE(safety_on_setpoint(&s, EN, 1300));
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK(safety_status(&s) == (PROTO_F_CMD_TIMEOUT | PROTO_ST_SETPOINT_OK));
    // ... clearing without enable clears but stays stopped ...
    CHECK_FALSE(safety_on_setpoint(&s, CLR, 1310));
    CHECK(safety_status(&s) == PROTO_ST_SETPOINT_OK);
    // ... and enable + clear in one frame runs.
    safety_tick(&s, 1320);
    CHECK(safety_on_setpoint(&s, EN | CLR, 1320));
    CHECK(safety_motor_enabled(&s));
}

TEST_CASE("safety: a fresh setpoint each period keeps it running; timeout counts from the last")
{
    safety_t s = booted();
    uint32_t t = 0;
    for (; t < 5000; ++t) {
        if (t % 10 == 0) safety_on_setpoint(&s, EN, t);
        safety_tick(&s, t);
        REQUIRE(safety_motor_enabled(&s));
    }
    // last setpoint at 4990
    for (; t < 4990 + 250; ++t) safety_tick(&s, t);
    CHECK(safety_motor_enabled(&s));
    safety_tick(&s, 4990 + 250);
    CHECK(safety_status(&s) == PROTO_F_CMD_TIMEOUT);
}

TEST_CASE("safety: timeout while disabled is no fault")
{
    safety_t s = booted();
    safety_on_setpoint(&s, 0, 0);
    CHECK(safety_status(&s) == PROTO_ST_SETPOINT_OK);
    safety_tick(&s, 300);
    CHECK(safety_status(&s) == 0);
}

TEST_CASE("safety: disable setpoint stops without fault")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    CHECK_FALSE(safety_on_setpoint(&s, 0, 10));
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK(safety_status(&s) == PROTO_ST_SETPOINT_OK);
}

TEST_CASE("safety: timeout survives the 32-bit millisecond wrap")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0xFFFFFF00u);
    safety_tick(&s, 0xFFFFFF00u + 249u);
    CHECK(safety_motor_enabled(&s));
    safety_tick(&s, 0xFFFFFF00u + 250u); // wrapped to 0xFA
    CHECK_FALSE(safety_motor_enabled(&s));
}

TEST_CASE("safety: overcurrent needs 5 consecutive readings at or above 5200 mA")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    for (int i = 0; i < 4; ++i) safety_on_power(&s, 5200, 18000);
    safety_on_power(&s, 5199, 18000); // breaks the run
    for (int i = 0; i < 4; ++i) safety_on_power(&s, -5200, 18000); // either sign
    CHECK(safety_motor_enabled(&s));
    safety_on_power(&s, 6000, 18000);
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_OVERCURRENT);
    // Clearing resets the count: four more readings do not latch again.
    CHECK(safety_on_setpoint(&s, EN | CLR, 10));
    for (int i = 0; i < 4; ++i) safety_on_power(&s, 5200, 18000);
    CHECK(safety_motor_enabled(&s));
    safety_on_power(&s, 5200, 18000);
    CHECK_FALSE(safety_motor_enabled(&s));
}

TEST_CASE("safety: under-voltage latches below 16.0 V, clears only above 16.5 V")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    safety_on_power(&s, 1000, 16000); // exactly at the limit: fine
    CHECK(safety_motor_enabled(&s));
    // A surge's sag one reading short of UNDERVOLTAGE_SAMPLES, then recovery: no fault.
    for (int i = 0; i < UNDERVOLTAGE_SAMPLES - 1; ++i) safety_on_power(&s, 4000, 14000);
    safety_on_power(&s, 1000, 16000);
    CHECK(safety_motor_enabled(&s));
    // Low for UNDERVOLTAGE_SAMPLES readings in a row: latched.
    for (int i = 0; i < UNDERVOLTAGE_SAMPLES - 1; ++i) safety_on_power(&s, 1000, 15999);
    CHECK(safety_motor_enabled(&s));
    safety_on_power(&s, 1000, 15999);
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_UNDERVOLTAGE);
    // Recovered into the hysteresis band: clearing is refused.
    safety_on_power(&s, 0, 16499);
    CHECK_FALSE(safety_on_setpoint(&s, EN | CLR, 10));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_UNDERVOLTAGE);
    // Above the band: clearing works.
    safety_on_power(&s, 0, 16500);
    CHECK(safety_on_setpoint(&s, EN | CLR, 20));
    CHECK(safety_status(&s) == (PROTO_ST_ENABLED | PROTO_ST_SETPOINT_OK));
    // Dipping into the band from above is not a fault.
    safety_on_power(&s, 0, 16100);
    CHECK(safety_motor_enabled(&s));
}

TEST_CASE("safety: sensor fault latches until cleared, and not while still failing")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    safety_on_sensor_fault(&s);
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_SENSOR);
    // Still failing: clearing is refused.
    CHECK_FALSE(safety_on_setpoint(&s, EN | CLR, 5));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_SENSOR);
    safety_on_power(&s, 0, 18000); // a good reading alone does not clear it...
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_SENSOR);
    CHECK(safety_on_setpoint(&s, EN | CLR, 10)); // ... but allows clearing
}

TEST_CASE("safety: a watchdog reset is reported and must be cleared")
{
    safety_t s = booted(true);
    CHECK(safety_status(&s) == PROTO_F_WATCHDOG);
    CHECK_FALSE(safety_on_setpoint(&s, EN, 0));
    CHECK(safety_on_setpoint(&s, EN | CLR, 10));
    CHECK(safety_status(&s) == (PROTO_ST_ENABLED | PROTO_ST_SETPOINT_OK));
}

TEST_CASE("safety: a stall latches after stall_time_ms of voltage, current and no rotation")
{
    safety_t s = booted();  // defaults: 2000 mA motor current, 100 ms, 25 % of 12 V, 50 crpm
    REQUIRE(STALL_CURRENT_MA == 2000);
    REQUIRE(STALL_TIME_MS == 100);
    safety_on_setpoint(&s, EN, 0);
    const int32_t u_half = PID_U_ONE / 2;
    // Half of 12 V at 18 V: duty 3333; a locked rotor draws 10 A in the motor, 3.3 A from the
    // pack (the INA219's side).
    for (int i = 0; i < 9; ++i) safety_on_step(&s, u_half, 3333, 0, 3333);
    CHECK(safety_motor_enabled(&s));
    // One step that turned (2 counts per period) restarts the count.
    safety_on_step(&s, u_half, 3333, 68, 3333);
    for (int i = 0; i < 9; ++i) safety_on_step(&s, u_half, 3333, -34, 3333);
    CHECK(safety_motor_enabled(&s));
    safety_on_step(&s, u_half, 3333, 34, 3333);  // the tenth in a row: 100 ms
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK((safety_status(&s) & PROTO_F_MASK) == PROTO_F_STALL);
    CHECK(safety_take_new(&s) == PROTO_F_STALL);
    CHECK(safety_take_new(&s) == 0);  // handed out once
    // Cleared by CLEAR_FAULTS, and the count starts over.
    CHECK(safety_on_setpoint(&s, EN | CLR, 10));
    for (int i = 0; i < 9; ++i) safety_on_step(&s, -u_half, -3333, 0, 3333);  // either sign
    CHECK(safety_motor_enabled(&s));
    safety_on_step(&s, -u_half, -3333, 0, 3333);
    CHECK_FALSE(safety_motor_enabled(&s));
    CHECK(safety_take_new(&s) == PROTO_F_STALL);  // a new latch is handed out again
}

TEST_CASE("safety: no stall without voltage, without current, or while turning")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    const int32_t u_quarter = PID_U_ONE / 4;
    for (int i = 0; i < 50; ++i) {
        // Below a quarter of the rated voltage: holding against a load at rest is no stall.
        safety_on_step(&s, u_quarter - 1, 1428, 0, 2000);
        // An encoder that stopped counting: the free motor draws 0.5 A, below 2 A (pack
        // current 0.5 A x duty 0.5 = 0.25 A).
        safety_on_step(&s, u_quarter * 2, 5000, 0, 250);
        // Turning slowly under a heavy load: 1.7 rpm.
        safety_on_step(&s, u_quarter * 3, 7500, 170, 7000);
    }
    CHECK(safety_motor_enabled(&s));
    // Detection off (stall_current_ma 0).
    proto_config_t cfg;
    settings_defaults(&cfg);
    cfg.stall_current_ma = 0;
    safety_configure(&s, &cfg);
    for (int i = 0; i < 50; ++i) safety_on_step(&s, PID_U_ONE, 5714, 0, 9000);
    CHECK(safety_motor_enabled(&s));
}

TEST_CASE("safety: every latched fault is handed out once, as it latches")
{
    safety_t s = booted();
    safety_on_setpoint(&s, EN, 0);
    CHECK(safety_take_new(&s) == 0);
    for (int i = 0; i < 5; ++i) safety_on_power(&s, 6000, 18000);
    CHECK(safety_take_new(&s) == PROTO_F_OVERCURRENT);
    safety_on_sensor_fault(&s);
    CHECK(safety_take_new(&s) == PROTO_F_SENSOR);  // only the new bit
    CHECK(safety_take_new(&s) == 0);
    // A watchdog reset at boot is latched too; main.c takes it so no FAULT frame is sent.
    safety_t w = booted(true);
    CHECK(safety_take_new(&w) == PROTO_F_WATCHDOG);
}
