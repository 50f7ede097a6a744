/* Test rig only, never installed: qemu-user 7.2 (Debian 12) answers ENOSYS to the termios2
 * ioctls (TCGETS2/TCSETS2) that host/io/serial_baud.cpp uses to set 250000 baud, so the
 * aarch64 augerd and auger-module could not open a port under qemu-aarch64 at all. Preloaded
 * into them (qemu-aarch64 -E LD_PRELOAD=...) by qemu_augerd.sh, this maps the two ioctls onto
 * TCGETS/TCSETS, which qemu translates: everything of termios2 but the rate, and the rate means
 * nothing on the pty of a simulated module. On the board (a real kernel) the ioctls are the
 * kernel's and this file plays no part. */
#define _GNU_SOURCE
#include <asm/ioctls.h>
#include <asm/termbits.h>
#include <dlfcn.h>
#include <stdarg.h>

int ioctl(int fd, unsigned long request, ...)
{
	static int (*real_ioctl)(int, unsigned long, ...);
	if (!real_ioctl)
		real_ioctl = (int (*)(int, unsigned long, ...))dlsym(RTLD_NEXT, "ioctl");
	va_list ap;
	va_start(ap, request);
	void *arg = va_arg(ap, void *);
	va_end(ap);
	if (request == TCGETS2) {
		/* The kernel's struct termios is the prefix of struct termios2. */
		struct termios2 *t = arg;
		int r = real_ioctl(fd, TCGETS, t);
		if (r == 0)
			t->c_ispeed = t->c_ospeed = 0;
		return r;
	}
	if (request == TCSETS2) {
		struct termios2 t = *(const struct termios2 *)arg;
		t.c_cflag = (t.c_cflag & ~(tcflag_t)CBAUD) | B38400;  /* BOTHER has no TCSETS meaning */
		return real_ioctl(fd, TCSETS, &t);
	}
	return real_ioctl(fd, request, arg);
}
