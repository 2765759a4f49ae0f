/* uros probe: what main.c and transport.c (portable) need from a machine's board files
 * (board/: the architecture's start-up, its UART driver, the machine's numbers in probe_machine.h). */
#ifndef UROS_PROBE_H
#define UROS_PROBE_H
#include <stddef.h>
#include <stdint.h>

uint32_t probe_millis(void);
size_t probe_heap_used(void);
size_t probe_stack_used(void);
/* Every end of the run passes it first (board.c's _exit): the status QEMU exits with. */
int probe_exit_status(int status);

/* The UART the agent talks to (polled). */
void probe_link_init(void);
void probe_link_put(uint8_t byte);
int probe_link_get(void); /* the next byte received, or -1 when none is waiting */

/* The firmware's text: a second UART, or semihosting on a machine with one UART. */
void probe_console_init(void);
void probe_console_put(uint8_t byte);
#endif
