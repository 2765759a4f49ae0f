/* uros probe: the CMSDK APB UART of QEMU's mps2/mps3 boards (hw/char/cmsdk-apb-uart.c): DATA, STATE
 * (bit 0 TX full, bit 1 RX full), CTRL. The link is one UART, the console (when the machine has a
 * second one) the other; the addresses come from probe_machine.h. */
#include "probe.h"
#include "probe_machine.h"

typedef struct {
  volatile uint32_t DATA, STATE, CTRL, INTSTATUS, BAUDDIV;
} cmsdk_uart_t;
#define LINK ((cmsdk_uart_t *)PROBE_LINK_BASE)

static void cmsdk_enable(cmsdk_uart_t *uart) {
  uart->BAUDDIV = 16u; /* the model ignores the rate but wants a divider >= 16 */
  uart->CTRL = 0x3u;   /* TX and RX enabled */
}

static void cmsdk_put(cmsdk_uart_t *uart, uint8_t byte) {
  while (uart->STATE & 1u) {
  }
  uart->DATA = byte;
}

void probe_link_init(void) { cmsdk_enable(LINK); }
void probe_link_put(uint8_t byte) { cmsdk_put(LINK, byte); }
int probe_link_get(void) { return (LINK->STATE & 2u) ? (int)(LINK->DATA & 0xFFu) : -1; }

#ifdef PROBE_CONSOLE_BASE
#define CONSOLE ((cmsdk_uart_t *)PROBE_CONSOLE_BASE)
void probe_console_init(void) { cmsdk_enable(CONSOLE); }
void probe_console_put(uint8_t byte) { cmsdk_put(CONSOLE, byte); }
#endif
