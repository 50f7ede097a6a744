/*
 * Build-time parameters of the motor module and the checks that reject impossible
 * combinations. Every value can be overridden on the make command line
 * (`make -C firmware SHUNT_MOHM=100 OVERCURRENT_MA=2500`); the values here are the
 * defaults, and the EEPROM settings (settings.h) override the run-time ones.
 * Free of <avr/io.h>: the host unit tests include it too.
 */
#ifndef AUGER_CONFIG_H
#define AUGER_CONFIG_H

/* ---- firmware identity ---------------------------------------------------------------- */
#define FW_VERSION_MAJOR 0
#define FW_VERSION_MINOR 2
#define FW_VERSION_PATCH 0

/* ---- per-module settings: defaults of the EEPROM settings ------------------------------- */
#ifndef MODULE_ID
#define MODULE_ID 0
#endif
#ifndef DIR_SIGN
#define DIR_SIGN 1
#endif
/* 12 encoder cycles per motor revolution, X4 decoded (docs/model-notes.md, from sibling models). */
#ifndef ENC_COUNTS_PER_MOTOR_REV
#define ENC_COUNTS_PER_MOTOR_REV 48
#endif
/* Gear ratio x100. 369:1 is an ESTIMATE extrapolated from the 45 and 313 RPM models; the
 * 23 RPM model's ratio is not published. Measure it on a real motor and set it per module. */
#ifndef GEAR_RATIO_X100
#define GEAR_RATIO_X100 36900
#endif
#define COUNTS_PER_REV_X100 (ENC_COUNTS_PER_MOTOR_REV * 1UL * GEAR_RATIO_X100)

/* Velocity PID gains, eqs. (23)-(24), in the units below (e: screw rpm, u: share of the
 * motor's rated voltage, T: s). The paper's kp 0.5, ki 0.0003, kd 0.005 give no working loop
 * under any reading of their units (docs/firmware.md, measured with tests/fil/pid_units); these
 * were tuned in the firmware-in-the-loop simulation: 0 -> 10 rpm rises in 0.05 s with at
 * most one encoder count of overshoot at 15 V and at 21 V. The paper's build:
 * make -C firmware KP=0.5 KI=0.0003 KD=0.005. */
#ifndef KP
#define KP 0.03
#endif
#ifndef KI
#define KI 1.5
#endif
#ifndef KD
#define KD 0.0
#endif

#ifndef OMEGA_MAX_CRPM
#define OMEGA_MAX_CRPM 3000 /* 30 rpm; the motor does about 23 rpm at 12 V */
#endif
#ifndef OVERCURRENT_MA
#define OVERCURRENT_MA 5200 /* the group's code: 5 readings of 5.2 A or more */
#endif
#ifndef OVERCURRENT_SAMPLES
#define OVERCURRENT_SAMPLES 5
#endif
#ifndef UNDERVOLTAGE_MV
#define UNDERVOLTAGE_MV 16000 /* five Li-ion cells at 3.2 V */
#endif
#ifndef UNDERVOLTAGE_HYST_MV
#define UNDERVOLTAGE_HYST_MV 500
#endif
/* Consecutive INA219 readings (10 ms apart) below undervoltage_mv before the fault latches.
 * A current surge sags the pack through its internal resistance (about 0.3 ohm for five
 * 18650 cells and wiring: 3 V at 10 A) for as long as the surge lasts; an empty pack stays
 * low. 200 ms tells the two apart and is harmless to the cells. */
#ifndef UNDERVOLTAGE_SAMPLES
#define UNDERVOLTAGE_SAMPLES 20
#endif
#ifndef MOTOR_RATED_MV
#define MOTOR_RATED_MV 12000
#endif
#ifndef CMD_TIMEOUT_MS
#define CMD_TIMEOUT_MS 250
#endif
/* Current foldback (foldback.h): from this pack current up to OVERCURRENT_MA the output is
 * derated linearly to zero; 0 turns it off. 4.5 A leaves the firmware-in-the-loop loads
 * above what the heaviest load of the firmware-in-the-loop tests draws (docs/firmware.md). */
#ifndef FOLDBACK_MA
#define FOLDBACK_MA 4500
#endif
/* Stall detection (safety.h): motor current (pack current / duty) of at least this, with at
 * least STALL_U_MIN_PCT of the rated voltage on the motor and at most STALL_SPEED_CRPM, for
 * STALL_TIME_MS in a row, latches PROTO_F_STALL. A locked rotor with a quarter of 12 V draws
 * 5 A; the free motor 0.5 A, so an encoder that stopped counting is not taken for a stall.
 * STALL_CURRENT_MA 0 turns it off. */
#ifndef STALL_CURRENT_MA
#define STALL_CURRENT_MA 2000
#endif
#ifndef STALL_TIME_MS
#define STALL_TIME_MS 100
#endif
#ifndef STALL_U_MIN_PCT
#define STALL_U_MIN_PCT 25
#endif
/* 1 count per 10 ms reads 34 crpm: at most one count per period is "no rotation". */
#ifndef STALL_SPEED_CRPM
#define STALL_SPEED_CRPM 50
#endif
/* Telemetry every 10, 20, 50 or 100 ms (the control step stays at 10 ms). */
#ifndef TELEMETRY_PERIOD_MS
#define TELEMETRY_PERIOD_MS 10
#endif

/* ---- control loop ------------------------------------------------------------------------- */
#define TICK_HZ 1000u          /* Timer2 tick: 16 MHz / 128 / 125 */
#define CONTROL_PERIOD_MS 10u  /* 100 Hz: control step, INA219 cycle, telemetry */
/* The INA219 cycle starts at the period's tick and the control step runs when its reading
 * is in (the longest cycle, five transactions, takes 0.75 ms; a cycle still running at the
 * next tick is stepped without), so the current foldback acts on a fresh reading. */

/* PID sample time T of eq. (24), in the unit the gains assume (seconds by default). */
#ifndef PID_T
#define PID_T 0.01
#endif
/* Units of eqs. (23)-(24), an open question (docs/model-notes.md): the error e fed to the PID is
 * omega error [rpm] * PID_E_PER_RPM, and u = PID_U_FULL means the motor's rated voltage
 * (duty = u / PID_U_FULL * motor_rated_mv / battery_mv). Defaults: e in screw rpm, u the
 * share of the rated voltage (-1..1). */
#ifndef PID_E_PER_RPM
#define PID_E_PER_RPM 1.0
#endif
#ifndef PID_U_FULL
#define PID_U_FULL 1.0
#endif

/* ---- INA219 -------------------------------------------------------------------------------- */
#ifndef INA_ADDR
#define INA_ADDR 0x40
#endif
/* Shunt resistance in milliohm. 10 mOhm with the 320 mV range reads up to 32 A, above the
 * motor's stall current, with 10 uV (= 1 mA) shunt resolution. */
#ifndef SHUNT_MOHM
#define SHUNT_MOHM 10
#endif
/* Shunt voltage range (PGA): 40, 80, 160 or 320 mV. */
#ifndef INA_PGA_MV
#define INA_PGA_MV 320
#endif
/* Current register LSB in microampere; 1000 uA makes the register read mA directly. */
#ifndef CURRENT_LSB_UA
#define CURRENT_LSB_UA 1000
#endif
/* Consecutive failed INA219 cycles before PROTO_F_SENSOR latches (one cycle per 10 ms). */
#ifndef INA_FAIL_CYCLES
#define INA_FAIL_CYCLES 3
#endif
/* The configuration is read back (and the calibration rewritten) every this many cycles,
 * and at once when the current reads exactly 0 with the motor driven (ina219.c: a reset
 * chip's current register reads 0). */
#ifndef INA_VERIFY_CYCLES
#define INA_VERIFY_CYCLES 10
#endif
/* The bus voltage is read every this many INA219 cycles while the pack is above
 * undervoltage_mv + undervoltage_hyst_mv, every cycle once a reading is below that: a low pack is
 * seen within INA_BUS_CYCLES x 10 ms, and the under-voltage filter (UNDERVOLTAGE_SAMPLES)
 * then counts fresh readings, so it trips within (INA_BUS_CYCLES + UNDERVOLTAGE_SAMPLES) x
 * 10 ms of the drop (280 ms) and a sag shorter than UNDERVOLTAGE_SAMPLES x 10 ms never
 * trips. The duty cap follows the pack at 12.5 Hz. */
#ifndef INA_BUS_CYCLES
#define INA_BUS_CYCLES 8
#endif
/* Longest wait for one TWI transaction, ms (a 6-byte transaction takes 0.15 ms at 400 kHz). */
#define TWI_TIMEOUT_MS 3u
#define TWI_SCL_HZ 400000UL

/* Derived INA219 values (datasheet section 8.5): cal = trunc(0.04096 / (current_LSB * R)). */
#define INA_CAL (40960000UL / (CURRENT_LSB_UA * 1UL * SHUNT_MOHM))
/* Full scale: the PGA range over the shunt, or the current register's range, whichever is less. */
#define INA_PGA_FULL_SCALE_MA (INA_PGA_MV * 1000UL / SHUNT_MOHM)
#define INA_REG_FULL_SCALE_MA (32767UL * CURRENT_LSB_UA / 1000UL)
#define INA_FULL_SCALE_MA \
    (INA_PGA_FULL_SCALE_MA < INA_REG_FULL_SCALE_MA ? INA_PGA_FULL_SCALE_MA : INA_REG_FULL_SCALE_MA)

#if INA_PGA_MV == 40
#define INA_PGA_BITS 0
#elif INA_PGA_MV == 80
#define INA_PGA_BITS 1
#elif INA_PGA_MV == 160
#define INA_PGA_BITS 2
#elif INA_PGA_MV == 320
#define INA_PGA_BITS 3
#else
#error "INA_PGA_MV must be 40, 80, 160 or 320"
#endif
/* Config register: BRNG = 1 (32 V range), PGA, bus and shunt ADC 12 bit with 8-sample
 * averaging (4.26 ms each: averages the 16 kHz PWM ripple and fits the 10 ms period),
 * continuous shunt and bus conversion. */
#define INA_CONFIG_VALUE \
    ((1u << 13) | ((INA_PGA_BITS + 0u) << 11) | (0xBu << 7) | (0xBu << 3) | 0x7u)

/* ---- checks ----------------------------------------------------------------------------------- */
#if SHUNT_MOHM < 1
#error "SHUNT_MOHM must be at least 1"
#endif
#if CURRENT_LSB_UA < 1
#error "CURRENT_LSB_UA must be at least 1"
#endif
#if INA_CAL < 1 || INA_CAL > 0xFFFE
#error "INA219 calibration out of range: choose another CURRENT_LSB_UA for this SHUNT_MOHM"
#endif
#if OVERCURRENT_MA >= INA_FULL_SCALE_MA
#error "OVERCURRENT_MA is at or above the INA219's full-scale current for this shunt and range"
#endif
#if OVERCURRENT_MA < 1 || OVERCURRENT_MA > 65535
#error "OVERCURRENT_MA out of range"
#endif
#if OVERCURRENT_SAMPLES < 1 || OVERCURRENT_SAMPLES > 255
#error "OVERCURRENT_SAMPLES must be 1..255"
#endif
#if DIR_SIGN != 1 && DIR_SIGN != -1
#error "DIR_SIGN must be +1 or -1"
#endif
#if MODULE_ID < 0 || MODULE_ID > 255
#error "MODULE_ID must be 0..255"
#endif
#if ENC_COUNTS_PER_MOTOR_REV < 1 || GEAR_RATIO_X100 < 1
#error "ENC_COUNTS_PER_MOTOR_REV and GEAR_RATIO_X100 must be positive"
#endif
#if OMEGA_MAX_CRPM < 1 || OMEGA_MAX_CRPM > 32767
#error "OMEGA_MAX_CRPM must be 1..32767 (the setpoint is an int16 in 0.01 rpm)"
#endif
#if UNDERVOLTAGE_MV + UNDERVOLTAGE_HYST_MV >= 32000
#error "UNDERVOLTAGE_MV + UNDERVOLTAGE_HYST_MV must be below the INA219's 32 V range"
#endif
#if MOTOR_RATED_MV < 1000 || MOTOR_RATED_MV > 32000
#error "MOTOR_RATED_MV must be 1000..32000"
#endif
#if CMD_TIMEOUT_MS < 2 * CONTROL_PERIOD_MS || CMD_TIMEOUT_MS > 10000
#error "CMD_TIMEOUT_MS must be 20..10000"
#endif
#if INA_FAIL_CYCLES < 1 || INA_FAIL_CYCLES > 255
#error "INA_FAIL_CYCLES must be 1..255"
#endif
#if INA_BUS_CYCLES < 1 || INA_BUS_CYCLES > 255
#error "INA_BUS_CYCLES must be 1..255"
#endif
#if INA_VERIFY_CYCLES < 1 || INA_VERIFY_CYCLES > 255
#error "INA_VERIFY_CYCLES must be 1..255"
#endif
#if FOLDBACK_MA != 0 && FOLDBACK_MA >= OVERCURRENT_MA
#error "FOLDBACK_MA must be 0 (off) or below OVERCURRENT_MA"
#endif
#if STALL_CURRENT_MA < 0 || STALL_CURRENT_MA > 32767
#error "STALL_CURRENT_MA must be 0..32767"
#endif
#if STALL_TIME_MS < CONTROL_PERIOD_MS || STALL_TIME_MS > 2550
#error "STALL_TIME_MS must be 10..2550"
#endif
#if STALL_U_MIN_PCT < 1 || STALL_U_MIN_PCT > 100
#error "STALL_U_MIN_PCT must be 1..100"
#endif
#if TELEMETRY_PERIOD_MS != 10 && TELEMETRY_PERIOD_MS != 20 && TELEMETRY_PERIOD_MS != 50 && \
    TELEMETRY_PERIOD_MS != 100
#error "TELEMETRY_PERIOD_MS must be 10, 20, 50 or 100"
#endif

#endif /* AUGER_CONFIG_H */
