/* uros probe: what board.c, transport.c and main.c share. */
#ifndef UROS_PROBE_H
#define UROS_PROBE_H
#include <stddef.h>
#include <stdint.h>

/* CMSDK APB UART (QEMU hw/char/cmsdk-apb-uart.c): DATA, STATE (bit 0 TX full, bit 1 RX full), CTRL. */
typedef struct {
  volatile uint32_t DATA, STATE, CTRL, INTSTATUS, BAUDDIV;
} probe_uart_t;
#define PROBE_CONSOLE ((probe_uart_t *)0x40004000u) /* UART0: -serial #1 */
#define PROBE_LINK ((probe_uart_t *)0x40005000u)    /* UART1: -serial #2, the agent's */

void uart_enable(probe_uart_t *uart);
uint32_t probe_millis(void);
size_t probe_heap_used(void);
size_t probe_stack_used(void);
#endif
