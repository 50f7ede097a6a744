/* EEPROM: blocking read at boot, byte-by-byte background write from the main loop (one
 * byte takes 3.4 ms; a whole settings image would stall the loop for 120 ms). */
#include "board.h"

#include <avr/eeprom.h>
#include <string.h>

#include "settings.h"

static uint8_t pending[SETTINGS_IMAGE_SIZE];
static uint8_t pending_len, pending_pos;
static uint16_t pending_addr;

void eeprom_read_image(uint16_t addr, uint8_t *data, uint8_t len)
{
    eeprom_read_block(data, (const void *)(uintptr_t)addr, len);
}

void eeprom_write_start(uint16_t addr, const uint8_t *data, uint8_t len)
{
    if (len > sizeof pending) len = sizeof pending;
    memcpy(pending, data, len);
    pending_addr = addr;
    pending_len = len;
    pending_pos = 0;
}

bool eeprom_poll(void)
{
    if (pending_pos >= pending_len) {
        /* Busy until the last byte is physically written. */
        if (pending_len != 0 && eeprom_is_ready()) pending_len = pending_pos = 0;
        return pending_len != 0;
    }
    if (!eeprom_is_ready()) return true;
    /* eeprom_update_byte reads first and writes only a changed byte; it returns without
     * waiting for the write to end, and the device is ready, so it does not block. */
    eeprom_update_byte((uint8_t *)(uintptr_t)(pending_addr + pending_pos), pending[pending_pos]);
    pending_pos++;
    return true;
}
