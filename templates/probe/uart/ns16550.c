/* uros probe: a 16550 UART (QEMU hw/char/serial.c: RISC-V virt's NS16550A, the lx60 board's 16550 with
 * registers 4 bytes apart), the agent's link; these machines have one UART, so the console goes
 * through semihosting (the board's probe_console_put). */
#include "probe.h"
#include "probe_machine.h"

#define REG(n) (*(volatile uint8_t *)(PROBE_LINK_BASE + ((n) << PROBE_UART_REG_SHIFT)))
#define RBR_THR REG(0)
#define IER REG(1)
#define FCR REG(2)
#define LCR REG(3)
#define LSR REG(5)

void probe_link_init(void) {
  IER = 0u;    /* polled */
  LCR = 0x03u; /* 8N1 */
  FCR = 0x07u; /* FIFOs on and cleared */
}

void probe_link_put(uint8_t byte) {
  while (!(LSR & 0x20u)) { /* THR empty */
  }
  RBR_THR = byte;
}

int probe_link_get(void) { return (LSR & 0x01u) ? (int)RBR_THR : -1; }
