/*
 * pty_bridge: a pseudo-terminal standing in for a module's USB serial port. The
 * simulator holds the master side; a host program opens the slave through a stable
 * symlink (e.g. /tmp/auger-sim/module0). Raw mode, non-blocking. Detects a host opening
 * the port (the master stops reporting POLLHUP), as DTR would on a real board.
 */
#ifndef AUGER_SIM_PTY_BRIDGE_H
#define AUGER_SIM_PTY_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pty_bridge_t {
	int master_fd;
	char slave_path[64];
	char link_path[512];
	int host_open;       /* a host has the slave open */
} pty_bridge_t;

/* Open a pty and point link_path (if not NULL or empty) at its slave. 0 or -1. */
int pty_bridge_open(pty_bridge_t *b, const char *link_path);
void pty_bridge_close(pty_bridge_t *b);
/* Read what the host wrote: bytes read (0 when none). */
size_t pty_bridge_read(pty_bridge_t *b, uint8_t *buf, size_t len);
/* Write to the host; bytes the host has no room for are dropped (as a UART would). */
void pty_bridge_write(pty_bridge_t *b, const uint8_t *buf, size_t len);
/* Update host_open; returns 1 when a host has just opened the port. */
int pty_bridge_poll_open(pty_bridge_t *b);

#ifdef __cplusplus
}
#endif
#endif
