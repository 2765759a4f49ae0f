/* uros probe: the four callbacks of rmw_uros_set_custom_transport over UART1. The XRCE-DDS client
 * frames the stream itself (framing = true); these only move bytes. QEMU's UART holds one received
 * byte and stops reading the host side while it is full, so polling loses nothing. */
#include <stdbool.h>
#include <uxr/client/transport.h>

#include "probe.h"

bool probe_open(struct uxrCustomTransport *transport) {
  (void)transport;
  uart_enable(PROBE_LINK);
  return true;
}

bool probe_close(struct uxrCustomTransport *transport) {
  (void)transport;
  return true;
}

size_t probe_write(struct uxrCustomTransport *transport, const uint8_t *data, size_t length, uint8_t *error) {
  (void)transport;
  (void)error;
  for (size_t i = 0; i < length; i++) {
    while (PROBE_LINK->STATE & 1u) {
    }
    PROBE_LINK->DATA = data[i];
  }
  return length;
}

/* The first byte within `timeout` ms, then every byte that follows with gaps under 2 ms. */
size_t probe_read(struct uxrCustomTransport *transport, uint8_t *data, size_t length, int timeout, uint8_t *error) {
  (void)transport;
  (void)error;
  size_t got = 0;
  uint32_t start = probe_millis();
  while (!(PROBE_LINK->STATE & 2u)) {
    if ((int32_t)(probe_millis() - start) >= timeout) return 0;
  }
  uint32_t last = probe_millis();
  while (got < length && probe_millis() - last < 2u) {
    if (PROBE_LINK->STATE & 2u) {
      data[got++] = (uint8_t)PROBE_LINK->DATA;
      last = probe_millis();
    }
  }
  return got;
}
