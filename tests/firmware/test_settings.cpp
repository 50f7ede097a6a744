// Settings: defaults, validation of a received configuration, EEPROM image round trip.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>

#include "config.h"
#include "settings.h"

namespace {
proto_config_t defaults()
{
    proto_config_t c;
    settings_defaults(&c);
    return c;
}

proto_config_t custom()
{
    proto_config_t c = defaults();
    c.module_id = 3;
    c.dir_sign = -1;
    c.counts_per_rev_x100 = 1234567;
    c.kp = 0.8f;
    c.ki = 0.25f;
    c.kd = 0.0f;
    c.omega_max_crpm = 2500;
    c.overcurrent_ma = 4000;
    c.overcurrent_samples = 3;
    c.undervoltage_mv = 15500;
    c.undervoltage_hyst_mv = 700;
    c.motor_rated_mv = 11000;
    c.cmd_timeout_ms = 300;
    c.foldback_ma = 3500;
    c.stall_current_ma = 2500;
    c.stall_time_ms = 150;
    c.telemetry_period_ms = 50;
    return c;
}
} // namespace

TEST_CASE("settings: build defaults are valid and as documented")
{
    proto_config_t c = defaults();
    CHECK(settings_validate(&c) == SETTINGS_OK);
    CHECK(c.dir_sign == 1);
    CHECK(c.counts_per_rev_x100 == 48u * 36900u);
    CHECK(c.kp == 0.03f);  // tuned in simulation; the paper's 0.5 / 0.0003 / 0.005 do not work
    CHECK(c.ki == 1.5f);
    CHECK(c.kd == 0.0f);
    CHECK(c.overcurrent_ma == 5200);
    CHECK(c.overcurrent_samples == 5);
    CHECK(c.undervoltage_mv == 16000);
    CHECK(c.motor_rated_mv == 12000);
    CHECK(c.cmd_timeout_ms == 250);
    CHECK(c.foldback_ma == 4500);
    CHECK(c.stall_current_ma == 2000);
    CHECK(c.stall_time_ms == 100);
    CHECK(c.telemetry_period_ms == 10);
    CHECK(c.flags == 0);
}

TEST_CASE("settings: validation rejects what the module cannot use")
{
    proto_config_t c = custom();
    REQUIRE(settings_validate(&c) == SETTINGS_OK);

    SECTION("dir_sign must be +-1")
    {
        for (int8_t d : {int8_t(0), int8_t(2), int8_t(-2), int8_t(127)}) {
            c.dir_sign = d;
            CHECK(settings_validate(&c) == SETTINGS_E_DIR_SIGN);
        }
    }
    SECTION("reserved flags") { c.flags = 1; CHECK(settings_validate(&c) == SETTINGS_E_FLAGS); }
    SECTION("counts per revolution")
    {
        c.counts_per_rev_x100 = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_COUNTS);
        c.counts_per_rev_x100 = 99;
        CHECK(settings_validate(&c) == SETTINGS_E_COUNTS);
        c.counts_per_rev_x100 = 100;
        CHECK(settings_validate(&c) == SETTINGS_OK);
    }
    SECTION("gains finite and non-negative")
    {
        c.kp = std::numeric_limits<float>::quiet_NaN();
        CHECK(settings_validate(&c) == SETTINGS_E_GAINS);
        c.kp = 0.5f;
        c.ki = std::numeric_limits<float>::infinity();
        CHECK(settings_validate(&c) == SETTINGS_E_GAINS);
        c.ki = 0.0f;
        c.kd = -0.001f;
        CHECK(settings_validate(&c) == SETTINGS_E_GAINS);
    }
    SECTION("omega max")
    {
        c.omega_max_crpm = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_OMEGA_MAX);
        c.omega_max_crpm = 32768;
        CHECK(settings_validate(&c) == SETTINGS_E_OMEGA_MAX);
    }
    SECTION("overcurrent strictly below the sensor's full scale")
    {
        c.overcurrent_ma = uint16_t(INA_FULL_SCALE_MA);
        CHECK(settings_validate(&c) == SETTINGS_E_OVERCURRENT);
        c.overcurrent_ma = uint16_t(INA_FULL_SCALE_MA - 1);
        CHECK(settings_validate(&c) == SETTINGS_OK);
        c.overcurrent_ma = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_OVERCURRENT);
        c.overcurrent_ma = 5200;
        c.overcurrent_samples = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_OVERCURRENT);
    }
    SECTION("under-voltage inside the 32 V range")
    {
        c.undervoltage_mv = 31600;
        c.undervoltage_hyst_mv = 400;
        CHECK(settings_validate(&c) == SETTINGS_E_UNDERVOLTAGE);
    }
    SECTION("motor rating")
    {
        c.motor_rated_mv = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_MOTOR_RATED);
    }
    SECTION("command timeout")
    {
        c.cmd_timeout_ms = 0;
        CHECK(settings_validate(&c) == SETTINGS_E_TIMEOUT);
        c.cmd_timeout_ms = 19;
        CHECK(settings_validate(&c) == SETTINGS_E_TIMEOUT);
        c.cmd_timeout_ms = 20;
        CHECK(settings_validate(&c) == SETTINGS_OK);
    }
    SECTION("foldback off, or starting below the overcurrent trip")
    {
        c.foldback_ma = c.overcurrent_ma;
        CHECK(settings_validate(&c) == SETTINGS_E_FOLDBACK);
        c.foldback_ma = uint16_t(c.overcurrent_ma - 1);
        CHECK(settings_validate(&c) == SETTINGS_OK);
        c.foldback_ma = 0;
        CHECK(settings_validate(&c) == SETTINGS_OK);
    }
    SECTION("stall current and time")
    {
        c.stall_current_ma = 32768;
        CHECK(settings_validate(&c) == SETTINGS_E_STALL);
        c.stall_current_ma = 0; // off
        CHECK(settings_validate(&c) == SETTINGS_OK);
        c.stall_time_ms = 9;
        CHECK(settings_validate(&c) == SETTINGS_E_STALL);
        c.stall_time_ms = 2551;
        CHECK(settings_validate(&c) == SETTINGS_E_STALL);
        c.stall_time_ms = 2550;
        CHECK(settings_validate(&c) == SETTINGS_OK);
    }
    SECTION("telemetry period 10, 20, 50 or 100 ms")
    {
        for (int ms = 0; ms < 256; ++ms) {
            c.telemetry_period_ms = uint8_t(ms);
            const bool ok = ms == 10 || ms == 20 || ms == 50 || ms == 100;
            INFO(ms << " ms");
            CHECK((settings_validate(&c) == SETTINGS_OK) == ok);
            if (!ok) CHECK(settings_validate(&c) == SETTINGS_E_TELEMETRY_PERIOD);
        }
    }
}

TEST_CASE("settings: EEPROM image round trip")
{
    proto_config_t in = custom();
    uint8_t image[SETTINGS_IMAGE_SIZE];
    settings_to_image(&in, image);
    CHECK(image[0] == SETTINGS_LAYOUT_VERSION);
    // The payload is the protocol's CONFIG payload, byte for byte.
    uint8_t frame[PROTO_MAX_FRAME];
    proto_encode_config(&in, frame);
    CHECK(std::memcmp(image + 1, frame + PROTO_HEADER_SIZE, PROTO_LEN_CONFIG) == 0);

    proto_config_t out;
    std::memset(&out, 0, sizeof out);
    REQUIRE(settings_from_image(image, &out) == SETTINGS_FROM_IMAGE);
    CHECK(out.module_id == in.module_id);
    CHECK(out.dir_sign == in.dir_sign);
    CHECK(out.counts_per_rev_x100 == in.counts_per_rev_x100);
    CHECK(out.kp == in.kp);
    CHECK(out.ki == in.ki);
    CHECK(out.kd == in.kd);
    CHECK(out.omega_max_crpm == in.omega_max_crpm);
    CHECK(out.overcurrent_ma == in.overcurrent_ma);
    CHECK(out.overcurrent_samples == in.overcurrent_samples);
    CHECK(out.undervoltage_mv == in.undervoltage_mv);
    CHECK(out.undervoltage_hyst_mv == in.undervoltage_hyst_mv);
    CHECK(out.motor_rated_mv == in.motor_rated_mv);
    CHECK(out.cmd_timeout_ms == in.cmd_timeout_ms);
    CHECK(out.foldback_ma == in.foldback_ma);
    CHECK(out.stall_current_ma == in.stall_current_ma);
    CHECK(out.stall_time_ms == in.stall_time_ms);
    CHECK(out.telemetry_period_ms == in.telemetry_period_ms);
    CHECK(settings_identity_flags(SETTINGS_FROM_IMAGE) == PROTO_ID_FROM_EEPROM);
}

TEST_CASE("settings: corrupt, blank, old-layout or invalid images are refused, and told apart")
{
    proto_config_t in = custom();
    uint8_t image[SETTINGS_IMAGE_SIZE];
    settings_to_image(&in, image);
    proto_config_t out = defaults();
    const proto_config_t before = out;

    // Any single flipped bit: a flip in the version byte reads as another layout, anywhere
    // else the CRC catches it.
    for (unsigned bit = 0; bit < SETTINGS_IMAGE_SIZE * 8; ++bit) {
        uint8_t bad[SETTINGS_IMAGE_SIZE];
        std::memcpy(bad, image, sizeof bad);
        bad[bit / 8] = uint8_t(bad[bit / 8] ^ (1u << (bit % 8)));
        INFO("bit " << bit);
        CHECK(settings_from_image(bad, &out) == (bit < 8 ? SETTINGS_OLD_LAYOUT : SETTINGS_CORRUPT));
    }
    CHECK(std::memcmp(&out, &before, sizeof out) == 0); // untouched on failure

    uint8_t blank[SETTINGS_IMAGE_SIZE];
    std::memset(blank, 0xFF, sizeof blank); // erased EEPROM
    CHECK(settings_from_image(blank, &out) == SETTINGS_EMPTY);
    std::memset(blank, 0x00, sizeof blank);
    CHECK(settings_from_image(blank, &out) == SETTINGS_OLD_LAYOUT);

    // The layout of protocol 1 (version 1: the 32-byte CONFIG payload and its CRC), written
    // by the previous firmware: not converted, defaults.
    uint8_t v1[SETTINGS_IMAGE_SIZE];
    std::memset(v1, 0xFF, sizeof v1);
    v1[0] = 1;
    for (unsigned i = 1; i < 33; ++i) v1[i] = uint8_t(i * 7);
    const uint16_t crc = proto_crc(v1, 33);
    v1[33] = uint8_t(crc & 0xFF);
    v1[34] = uint8_t(crc >> 8);
    CHECK(settings_from_image(v1, &out) == SETTINGS_OLD_LAYOUT);

    // A good CRC over contents that do not validate.
    proto_config_t invalid = in;
    invalid.dir_sign = 0;
    settings_to_image(&invalid, image);
    CHECK(settings_from_image(image, &out) == SETTINGS_CORRUPT);
    CHECK(std::memcmp(&out, &before, sizeof out) == 0);

    CHECK(settings_identity_flags(SETTINGS_EMPTY) == 0);
    CHECK(settings_identity_flags(SETTINGS_OLD_LAYOUT) == PROTO_ID_SETTINGS_OLD_LAYOUT);
    CHECK(settings_identity_flags(SETTINGS_CORRUPT) == PROTO_ID_SETTINGS_CORRUPT);
}
