/* Board support micro-ROS needs on bare metal: a clock and the four custom-transport functions.
 * On an STM32H743 these wrap a hardware timer and the USB CDC (or UART DMA) driver; here they are
 * stubs with the right signatures so the firmware links. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include <uxr/client/transport.h>

#include "board.h"

volatile uint64_t board_ticks_ms; /* SysTick_Handler increments it on the real board */

/* rcutils and the XRCE-DDS client read the time through clock_gettime(); newlib on bare metal has
 * no implementation, so the firmware supplies it. */
int clock_gettime(clockid_t clock_id, struct timespec *tp) {
  (void)clock_id;
  uint64_t ms = board_ticks_ms;
  tp->tv_sec = (time_t)(ms / 1000u);
  tp->tv_nsec = (long)((ms % 1000u) * 1000000u);
  return 0;
}

bool board_transport_open(struct uxrCustomTransport *transport) {
  (void)transport;
  return true;
}

bool board_transport_close(struct uxrCustomTransport *transport) {
  (void)transport;
  return true;
}

size_t board_transport_write(struct uxrCustomTransport *transport, const uint8_t *buf, size_t len, uint8_t *err) {
  (void)transport;
  (void)buf;
  (void)err;
  return len; /* CDC_Transmit_HS(buf, len) on the board */
}

size_t board_transport_read(struct uxrCustomTransport *transport, uint8_t *buf, size_t len, int timeout,
                            uint8_t *err) {
  (void)transport;
  (void)buf;
  (void)len;
  (void)timeout;
  (void)err;
  return 0; /* bytes from the CDC receive ring buffer */
}
