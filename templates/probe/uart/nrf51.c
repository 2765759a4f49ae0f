/* uros probe: the nRF51 UART of QEMU's microbit (hw/char/nrf51_uart.c), the agent's link; the machine
 * has no second UART, so the console goes through semihosting (the board's probe_console_put). */
#include "probe.h"
#include "probe_machine.h"

#define REG(offset) (*(volatile uint32_t *)(PROBE_LINK_BASE + (offset)))
#define STARTRX REG(0x000)
#define STARTTX REG(0x008)
#define EVENTS_RXDRDY REG(0x108)
#define EVENTS_TXDRDY REG(0x11C)
#define ENABLE REG(0x500)
#define RXD REG(0x518)
#define TXD REG(0x51C)

void probe_link_init(void) {
  ENABLE = 4u;
  STARTTX = 1u;
  STARTRX = 1u;
  EVENTS_TXDRDY = 1u; /* nothing is being sent: the first put need not wait */
}

void probe_link_put(uint8_t byte) {
  while (!EVENTS_TXDRDY) {
  }
  EVENTS_TXDRDY = 0u;
  TXD = byte;
}

int probe_link_get(void) {
  if (!EVENTS_RXDRDY) return -1;
  EVENTS_RXDRDY = 0u;
  return (int)(RXD & 0xFFu);
}
