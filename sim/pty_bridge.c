/* pty bridge: posix_openpt master, raw termios, symlink to the slave. */
#define _XOPEN_SOURCE 600
#define _DEFAULT_SOURCE
#include "pty_bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

int pty_bridge_open(pty_bridge_t *b, const char *link_path)
{
	memset(b, 0, sizeof(*b));
	b->master_fd = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
	if (b->master_fd < 0)
		return -1;
	if (grantpt(b->master_fd) || unlockpt(b->master_fd))
		goto fail;
	const char *name = ptsname(b->master_fd);
	if (!name)
		goto fail;
	snprintf(b->slave_path, sizeof(b->slave_path), "%s", name);
	struct termios t;
	if (tcgetattr(b->master_fd, &t) == 0) {
		cfmakeraw(&t);
		tcsetattr(b->master_fd, TCSANOW, &t);
	}
	if (link_path && link_path[0]) {
		snprintf(b->link_path, sizeof(b->link_path), "%s", link_path);
		unlink(b->link_path);
		if (symlink(b->slave_path, b->link_path) != 0) {
			fprintf(stderr, "auger-sim: cannot link %s -> %s: %s\n", b->link_path,
					b->slave_path, strerror(errno));
			b->link_path[0] = 0;
			goto fail;
		}
	}
	/* a fresh master reports no hang-up until a slave has been opened and closed once:
	 * do it now, so that the host's first open is seen as one */
	int s = open(b->slave_path, O_RDWR | O_NOCTTY);
	if (s >= 0)
		close(s);
	pty_bridge_poll_open(b);
	return 0;
fail:
	close(b->master_fd);
	b->master_fd = -1;
	return -1;
}

void pty_bridge_close(pty_bridge_t *b)
{
	if (b->master_fd >= 0)
		close(b->master_fd);
	b->master_fd = -1;
	if (b->link_path[0])
		unlink(b->link_path);
	b->link_path[0] = 0;
}

size_t pty_bridge_read(pty_bridge_t *b, uint8_t *buf, size_t len)
{
	if (b->master_fd < 0)
		return 0;
	ssize_t n = read(b->master_fd, buf, len);
	return n > 0 ? (size_t)n : 0; /* EAGAIN, or EIO while no host has it open */
}

void pty_bridge_write(pty_bridge_t *b, const uint8_t *buf, size_t len)
{
	if (b->master_fd < 0 || !b->host_open)
		return;
	while (len) {
		ssize_t n = write(b->master_fd, buf, len);
		if (n <= 0)
			return;
		buf += n;
		len -= (size_t)n;
	}
}

int pty_bridge_poll_open(pty_bridge_t *b)
{
	if (b->master_fd < 0)
		return 0;
	struct pollfd pfd = { .fd = b->master_fd, .events = POLLIN, .revents = 0 };
	if (poll(&pfd, 1, 0) < 0)
		return 0;
	int open_now = !(pfd.revents & POLLHUP);
	int opened = open_now && !b->host_open;
	b->host_open = open_now;
	return opened;
}
