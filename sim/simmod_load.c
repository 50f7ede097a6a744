/* simmod's loaders: ELF symbols (for the stack painting read-back) and Intel HEX (a
 * bootloader image). */
#include "simmod_internal.h"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* ---- ELF symbols (for the stack painting read-back) ---- */

int simmod_elf_symbol(const char *path, const char *name, uint32_t *value)
{
	int found = 0;
	if (elf_version(EV_CURRENT) == EV_NONE)
		return 0;
	int fd = open(path, O_RDONLY);
	if (fd < 0)
		return 0;
	Elf *elf = elf_begin(fd, ELF_C_READ, NULL);
	Elf_Scn *scn = NULL;
	while (elf && !found && (scn = elf_nextscn(elf, scn)) != NULL) {
		GElf_Shdr sh;
		if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB)
			continue;
		Elf_Data *data = elf_getdata(scn, NULL);
		size_t n = sh.sh_entsize ? sh.sh_size / sh.sh_entsize : 0;
		for (size_t i = 0; data && i < n; i++) {
			GElf_Sym sym;
			if (!gelf_getsym(data, (int)i, &sym))
				continue;
			const char *s = elf_strptr(elf, sh.sh_link, sym.st_name);
			if (s && strcmp(s, name) == 0) {
				*value = (uint32_t)sym.st_value;
				found = 1;
				break;
			}
		}
	}
	if (elf)
		elf_end(elf);
	close(fd);
	return found;
}

/* ---- Intel HEX (simavr 1.6's reader rejects Optiboot's type 03 record) ---- */

static int hex_byte(const char *s)
{
	int v = 0;
	for (int i = 0; i < 2; i++) {
		char c = s[i];
		int d = c >= '0' && c <= '9' ? c - '0' : c >= 'A' && c <= 'F' ? c - 'A' + 10 :
				c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
		if (d < 0)
			return -1;
		v = v * 16 + d;
	}
	return v;
}

int simmod_load_ihex(const char *path, uint8_t *flash, uint32_t flash_size, uint32_t *lowest)
{
	FILE *f = fopen(path, "r");
	if (!f)
		return -1;
	char line[600];
	uint32_t base = 0;
	int ok = 0, any = 0;
	*lowest = flash_size;
	while (fgets(line, sizeof(line), f)) {
		if (line[0] != ':')
			continue;
		int n = hex_byte(line + 1), ah = hex_byte(line + 3), al = hex_byte(line + 5),
				type = hex_byte(line + 7);
		if (n < 0 || ah < 0 || al < 0 || type < 0 || strlen(line) < (size_t)(11 + 2 * n))
			break;
		int sum = n + ah + al + type;
		uint8_t data[256];
		for (int i = 0; i < n; i++) {
			int b = hex_byte(line + 9 + 2 * i);
			if (b < 0)
				goto done;
			data[i] = (uint8_t)b;
			sum += b;
		}
		int check = hex_byte(line + 9 + 2 * n);
		if (check < 0 || ((sum + check) & 0xFF) != 0)
			break;
		if (type == 0) {
			uint32_t addr = base + (uint32_t)((ah << 8) | al);
			if (addr + (uint32_t)n > flash_size) {
				/* Debian's optiboot_atmega328.hex has 20 bytes past 32 KiB: the chip
				 * has no such flash, drop them */
				fprintf(stderr, "auger-sim: %s: %d bytes at 0x%05x are beyond flash, ignored\n",
						path, n, (unsigned)addr);
				continue;
			}
			memcpy(flash + addr, data, (size_t)n);
			if (addr < *lowest)
				*lowest = addr;
			any = 1;
		} else if (type == 1) {
			ok = any;
			break;
		} else if (type == 2 && n == 2) {
			base = (uint32_t)((data[0] << 8) | data[1]) << 4;
		} else if (type == 4 && n == 2) {
			base = (uint32_t)((data[0] << 8) | data[1]) << 16;
		} /* 3 and 5: start addresses, meaningless for an AVR */
	}
done:
	fclose(f);
	return ok ? 0 : -1;
}
