/* uros probe: the four callbacks of rmw_uros_set_custom_transport over the machine's link UART. The
 * XRCE-DDS client frames the stream itself (framing = true); these only move bytes. QEMU's UARTs stop
 * reading the host side while their receive buffer is full, so polling loses nothing. */
#include <stdbool.h>
#include <uxr/client/transport.h>

#include "fleet.h"
#include "link.h"
#include "probe.h"

bool probe_open(struct uxrCustomTransport *transport) {
  (void)transport;
  probe_link_init();
  return true;
}

bool probe_close(struct uxrCustomTransport *transport) {
  (void)transport;
  return true;
}

size_t probe_write(struct uxrCustomTransport *transport, const uint8_t *data, size_t length, uint8_t *error) {
  (void)transport;
  (void)error;
  for (size_t i = 0; i < length; i++) probe_link_put(data[i]);
  return length;
}

/* The first byte within `timeout` ms, then every byte that follows with gaps under 2 ms. */
size_t probe_read(struct uxrCustomTransport *transport, uint8_t *data, size_t length, int timeout, uint8_t *error) {
  (void)transport;
  (void)error;
  size_t got = 0;
  uint32_t start = probe_millis();
  int byte;
  while ((byte = probe_link_get()) < 0) {
    if ((int32_t)(probe_millis() - start) >= timeout) return 0;
  }
  data[got++] = (uint8_t)byte;
  uint32_t last = probe_millis();
  while (got < length && probe_millis() - last < 2u) {
    if ((byte = probe_link_get()) >= 0) {
      data[got++] = (uint8_t)byte;
      last = probe_millis();
    }
  }
  return got;
}

int probe_transport_setup(void) {
  rmw_uros_set_custom_transport(true, NULL, probe_open, probe_close, probe_write, probe_read);
  return 0;
}

rmw_ret_t probe_ping(int timeout_ms, uint8_t attempts) { return rmw_uros_ping_agent(timeout_ms, attempts); }

/* rclc_support_init's own steps, with the board's client key set in between (fleet.h) */
rcl_ret_t probe_support_init(rclc_support_t *support, rcl_allocator_t *allocator) {
  rcl_init_options_t options = rcl_get_zero_initialized_init_options();
  rcl_ret_t ret = rcl_init_options_init(&options, *allocator);
  if (ret != RCL_RET_OK) return ret;
  probe_set_client_key(rcl_init_options_get_rmw_init_options(&options));
  ret = rclc_support_init_with_options(support, 0, NULL, &options, allocator);
  (void)rcl_init_options_fini(&options);
  return ret;
}
