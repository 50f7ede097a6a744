/*
 * simmod: N simulated motor modules (ATmega328P under simavr running a firmware ELF,
 * wired to docs/hardware.md's pins: MD20A + motor + gearbox + screw, quadrature encoder,
 * INA219, battery). The robot simulator and the tests advance them in simulated time
 * with simmod_step_to(), set the load on each screw and read back the shaft, the current
 * and the UART bytes; a pty per module lets a real host program talk to them.
 * docs/simulator.md describes the models and their parameters.
 *
 * Threads: simmod_step_to() may run modules on worker threads; every other function must
 * be called from the thread that calls simmod_step_to(), between calls. UART callbacks
 * run on that thread too, at the end of each step, with each byte's simulated time.
 */
#ifndef AUGER_SIM_SIMMOD_H
#define AUGER_SIM_SIMMOD_H

#include <stddef.h>
#include <stdint.h>

#include "battery.h"
#include "motor_model.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SIMMOD_MAX_MODULES 8

typedef struct simmod_t simmod_t;

/* One byte the module sent, at simulated time t_s (when the firmware wrote UDR0). */
typedef void (*simmod_uart_cb_t)(void *ctx, int module, uint8_t byte, double t_s);

typedef struct simmod_config_t {
	const char *elf_path;        /* firmware; required */
	int count;                   /* modules, 1..SIMMOD_MAX_MODULES */
	int realtime;                /* 0: batch (as fast as possible); 1: paced to the wall clock */
	int threads;                 /* worker threads incl. the caller; 0 = one per core (max 2) */
	const char *pty_dir;         /* if set: a pty per module, symlinked DIR/moduleN */
	int reset_on_open;           /* reset a module when a host opens its pty (DTR) */
	double clock_offset_ppm[SIMMOD_MAX_MODULES]; /* crystal error per module */
	const char *bootloader_hex;  /* optional Optiboot .hex: start there, as after reset */
	double physics_step_s;       /* motor integration step: 100 us */
	double shunt_ohm;            /* INA219 shunt: must match the firmware's build value */
	uint8_t ina219_addr7;        /* 0x40 */
	int encoder_counts_per_rev;  /* X4 counts per motor revolution: 48 */
	motor_params_t motor;
	battery_params_t battery;
	int verbose;                 /* simavr log level passed through (0: errors only) */
	int exact_pwm;               /* 1: simavr steps Timer1 (every PWM edge an event); 0: its
	                                PWM on OC1A from the registers (sim/pwm_model.h), faster */
} simmod_config_t;

void simmod_config_default(simmod_config_t *cfg);

/* NULL on error (message on stderr). */
simmod_t *simmod_create(const simmod_config_t *cfg);
void simmod_destroy(simmod_t *sim);

int simmod_count(const simmod_t *sim);
/* Advance every module to simulated time t_s (seconds since creation). */
void simmod_step_to(simmod_t *sim, double t_s);
double simmod_time_s(const simmod_t *sim);
/* 0 running; -1 the AVR crashed or stopped (e.g. slept with interrupts off). */
int simmod_state(const simmod_t *sim, int module);

/* ---- mechanics and power ---- */
double simmod_shaft_angle_rad(const simmod_t *sim, int module);   /* screw (output) */
double simmod_shaft_speed_rpm(const simmod_t *sim, int module);   /* screw (output) */
double simmod_motor_angle_rad(const simmod_t *sim, int module);   /* motor shaft */
double simmod_motor_current_a(const simmod_t *sim, int module);   /* armature, signed */
double simmod_battery_current_a(const simmod_t *sim, int module); /* what the INA219 sees */
double simmod_battery_voltage_v(const simmod_t *sim, int module); /* terminal */
double simmod_pwm_duty(const simmod_t *sim, int module);  /* from PB1's edges, 0..1 */
int simmod_dir_pin(const simmod_t *sim, int module);      /* PB0 level */
/* Seconds of the module's clock since PB1 last changed level: with the pin low and this
 * beyond one PWM period, the motor has been off for that long (when exactly it stopped). */
double simmod_pwm_quiet_s(const simmod_t *sim, int module);
/* Load torque on the screw, N m; positive opposes positive rotation. */
void simmod_set_load_torque(simmod_t *sim, int module, double torque_nm);
/* Charge the pack has delivered since creation, coulombs: the mean pack current over a
 * window is its difference divided by the window (what the INA219 averages). */
double simmod_battery_charge_c(const simmod_t *sim, int module);
/* Force the battery's terminal voltage (tests); v <= 0 returns to the pack model. */
void simmod_set_battery_voltage(simmod_t *sim, int module, double v);
void simmod_set_battery_soc(simmod_t *sim, int module, double soc);
/* The true X4 count on the encoder pins now (what a perfect decoder would hold). */
int64_t simmod_encoder_count(const simmod_t *sim, int module);
/* Reset the INA219 as a supply glitch would (config and calibration lost). */
void simmod_ina219_glitch(simmod_t *sim, int module);
/* A register of the simulated INA219 as the chip holds it (INA219_REG_*). */
uint16_t simmod_ina219_register(const simmod_t *sim, int module, uint8_t reg);
/* Hold the screw still (a rotor locked in rock) or let it go. */
void simmod_lock_shaft(simmod_t *sim, int module, int locked);
/* A passive load on the screw, N m per rpm, opposing its rotation (added to the load torque):
 * unlike a load torque it never drives the screw backwards. */
void simmod_set_load_viscous(simmod_t *sim, int module, double nm_per_rpm);

/* ---- UART ---- */
void simmod_set_uart_callback(simmod_t *sim, simmod_uart_cb_t cb, void *ctx);
/* Queue bytes to the module's RX; they arrive at the line rate. Returns 0. */
int simmod_uart_send(simmod_t *sim, int module, const uint8_t *data, size_t len);
/* Slave path of the module's pty ("" without one). */
const char *simmod_pty_path(const simmod_t *sim, int module);
/* The stable symlink to it ("" without one). */
const char *simmod_pty_link(const simmod_t *sim, int module);

/* ---- AVR ---- */
/* External reset (as the reset pin or DTR): MCUSR.EXTRF set. */
void simmod_reset(simmod_t *sim, int module);
/* A reset that leaves MCUSR as given (0x01 power-on, 0x02 external, 0x04 brown-out, 0x08
 * watchdog; 0: as a bootloader that cleared it leaves it). power_lost: the supply went away,
 * so RAM comes back as noise (a fixed pattern), else RAM keeps its contents. */
void simmod_reset_as(simmod_t *sim, int module, uint8_t mcusr, int power_lost);
/* The module's EEPROM (1 KiB on the ATmega328P): bytes written or read directly, as a
 * programmer would (e.g. a settings image of an older layout). 0, or -1 out of range. */
int simmod_eeprom_write(simmod_t *sim, int module, uint16_t addr, const uint8_t *data, size_t len);
int simmod_eeprom_read(simmod_t *sim, int module, uint16_t addr, uint8_t *data, size_t len);
/* Stack headroom: longest run of the paint byte between the end of .bss and the stack
 * pointer, in bytes; -1 if the ELF has no __bss_end/_end symbol. */
int simmod_stack_headroom(const simmod_t *sim, int module, uint8_t paint_byte);
/* The simavr core (struct avr_t *) for tests that need more. */
void *simmod_avr(simmod_t *sim, int module);
uint64_t simmod_cycles(const simmod_t *sim, int module);
/* Cycles the AVR spent asleep since creation (simavr skips them in one jump). CPU load over
 * a window = 1 - (sleep cycles / cycles) of the window. */
uint64_t simmod_sleep_cycles(const simmod_t *sim, int module);

/* ---- test and benchmark hooks ---- */
/* The module's encoder part (encoder.h), for a bench that drives its pins itself, e.g. at an
 * imposed edge rate (encoder_rate.h). */
struct encoder_t *simmod_encoder(simmod_t *sim, int module);

/* One avr_run() of a module: one instruction, or one sleep span; an interrupt taken at its
 * end leaves pc_after on the vector. simavr 1.6 adds no cycles for the interrupt response
 * (the chip: 4, 8 from sleep). Byte addresses. */
typedef struct simmod_step_info_t {
	uint32_t pc_before, pc_after;
	uint64_t cycle_before, cycle_after;
	uint64_t sleep_cycles; /* of cycle_after - cycle_before, asleep */
	uint16_t sp_after;     /* stack pointer after the step */
} simmod_step_info_t;
typedef void (*simmod_step_hook_t)(void *ctx, int module, const simmod_step_info_t *info);
/* Profilers: called after every avr_run() of the module (on the thread that runs it; use
 * threads = 1). About halves the simulation speed; NULL removes it. */
void simmod_set_step_hook(simmod_t *sim, int module, simmod_step_hook_t hook, void *ctx);

#ifdef __cplusplus
}
#endif
#endif
