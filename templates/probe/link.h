/* uros probe: the agent's link as the probe's and the app runner's code use it, whatever carries it:
 * transport.c (the custom transport over the link UART, serial framing) or net/udp.c (the library's
 * own UDP transport through lwIP on the LAN9118, the agent's address set at run time). */
#ifndef UROS_PROBE_LINK_H
#define UROS_PROBE_LINK_H
#include <rclc/rclc.h>
#include <rmw_microros/rmw_microros.h>
#include <stdint.h>

int probe_transport_setup(void); /* 0, or the link could not be made (the firmware has said why) */
rmw_ret_t probe_ping(int timeout_ms, uint8_t attempts);
rcl_ret_t probe_support_init(rclc_support_t *support, rcl_allocator_t *allocator);
#endif
