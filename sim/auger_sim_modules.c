/*
 * auger-sim-modules: run one or four simulated motor modules from a firmware ELF, each
 * behind a pty, batch or paced to real time. Prints one line per module on stdout:
 * "<index> <symlink> <pty>", then runs until --seconds of simulated time or SIGINT/SIGTERM.
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "simmod.h"

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
	(void)sig;
	stop_requested = 1;
}

static void usage(FILE *f)
{
	fprintf(f,
		"usage: auger-sim-modules --elf PATH [--count 1|4] [--batch|--realtime]\n"
		"         [--seconds S] [--pty-dir DIR] [--threads N] [--reset-on-open]\n"
		"         [--clock-offset-ppm PPM] [--bootloader HEX] [--battery-v V]\n"
		"         [--load-nm NM] [--no-pty] [--verbose] [--help] [--version]\n"
		"Without --seconds it runs until SIGINT or SIGTERM. --clock-offset-ppm gives\n"
		"module i an offset of +PPM, -PPM, +PPM/2, -PPM/2, ... (i = 0, 1, 2, 3...).\n");
}

static double wall_s(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
	simmod_config_t cfg;
	simmod_config_default(&cfg);
	cfg.realtime = 1;
	double seconds = -1, offset_ppm = 0, battery_v = 0, load_nm = 0;
	const char *pty_dir = "/tmp/auger-sim";
	int no_pty = 0;

	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		const char *next = i + 1 < argc ? argv[i + 1] : NULL;
#define NEED_ARG() do { if (!next) { usage(stderr); return 2; } i++; } while (0)
		if (!strcmp(a, "--elf")) { NEED_ARG(); cfg.elf_path = next; }
		else if (!strcmp(a, "--count")) { NEED_ARG(); cfg.count = atoi(next); }
		else if (!strcmp(a, "--batch")) cfg.realtime = 0;
		else if (!strcmp(a, "--realtime")) cfg.realtime = 1;
		else if (!strcmp(a, "--seconds")) { NEED_ARG(); seconds = atof(next); }
		else if (!strcmp(a, "--pty-dir")) { NEED_ARG(); pty_dir = next; }
		else if (!strcmp(a, "--no-pty")) no_pty = 1;
		else if (!strcmp(a, "--threads")) { NEED_ARG(); cfg.threads = atoi(next); }
		else if (!strcmp(a, "--reset-on-open")) cfg.reset_on_open = 1;
		else if (!strcmp(a, "--clock-offset-ppm")) { NEED_ARG(); offset_ppm = atof(next); }
		else if (!strcmp(a, "--bootloader")) { NEED_ARG(); cfg.bootloader_hex = next; }
		else if (!strcmp(a, "--battery-v")) { NEED_ARG(); battery_v = atof(next); }
		else if (!strcmp(a, "--load-nm")) { NEED_ARG(); load_nm = atof(next); }
		else if (!strcmp(a, "--verbose")) cfg.verbose = 1;
		else if (!strcmp(a, "--help") || !strcmp(a, "-h")) { usage(stdout); return 0; }
		else if (!strcmp(a, "--version")) { printf("auger-sim-modules %s\n", AUGER_VERSION); return 0; }
		else { fprintf(stderr, "auger-sim-modules: unknown option %s\n", a); usage(stderr); return 2; }
#undef NEED_ARG
	}
	if (!cfg.elf_path || cfg.count < 1 || cfg.count > SIMMOD_MAX_MODULES) {
		usage(stderr);
		return 2;
	}
	for (int i = 0; i < cfg.count; i++)
		cfg.clock_offset_ppm[i] = offset_ppm * ((i & 1) ? -1.0 : 1.0) / (double)(1 + i / 2);
	if (!no_pty) {
		if (mkdir(pty_dir, 0755) != 0 && errno != EEXIST) {
			fprintf(stderr, "auger-sim-modules: cannot create %s: %s\n", pty_dir, strerror(errno));
			return 1;
		}
		cfg.pty_dir = pty_dir;
	}

	/* libsimavr prints progress on stdout: keep stdout for our pty lines only */
	fflush(stdout);
	int out_fd = dup(STDOUT_FILENO);
	FILE *out = out_fd >= 0 ? fdopen(out_fd, "w") : NULL;
	if (!out || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
		perror("auger-sim-modules: stdout");
		return 1;
	}

	simmod_t *sim = simmod_create(&cfg);
	if (!sim)
		return 1;
	for (int i = 0; i < cfg.count; i++) {
		if (battery_v > 0)
			simmod_set_battery_voltage(sim, i, battery_v);
		simmod_set_load_torque(sim, i, load_nm);
		fprintf(out, "%d %s %s\n", i, simmod_pty_link(sim, i), simmod_pty_path(sim, i));
	}
	fflush(out);

	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	const double chunk_s = cfg.realtime ? 0.01 : 0.1;
	double t0 = wall_s();
	double t = 0;
	while (!stop_requested && (seconds < 0 || t < seconds)) {
		t += chunk_s;
		if (seconds >= 0 && t > seconds)
			t = seconds;
		simmod_step_to(sim, t);
	}
	double wall = wall_s() - t0;
	fprintf(stderr, "auger-sim-modules: %d module(s), %.3f s simulated in %.3f s: %.1fx real time\n",
			cfg.count, simmod_time_s(sim), wall, wall > 0 ? simmod_time_s(sim) / wall : 0.0);
	for (int i = 0; i < cfg.count; i++)
		if (simmod_state(sim, i) != 0)
			fprintf(stderr, "auger-sim-modules: module %d stopped\n", i);
	simmod_destroy(sim);
	fclose(out);
	return 0;
}
