/* A minimal micro-ROS node for a bare-metal Cortex-M: publishes std_msgs/Int32 over a custom
 * transport. The four transport functions and clock_gettime() are the firmware's job on bare metal;
 * here they are stubs that a real board replaces with its UART/USB driver and a hardware timer. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include <rcl/rcl.h>
#include <rclc/rclc.h>
#include <rmw_microros/rmw_microros.h>
#include <std_msgs/msg/int32.h>
#include <uxr/client/transport.h>

/* -- board support: replace with the real driver -------------------------------------------- */
static volatile uint64_t ticks_ms; /* incremented by a SysTick handler on a real board */

int clock_gettime(clockid_t unused, struct timespec *tp) {
  (void)unused;
  tp->tv_sec = (time_t)(ticks_ms / 1000u);
  tp->tv_nsec = (long)((ticks_ms % 1000u) * 1000000u);
  return 0;
}

static bool transport_open(struct uxrCustomTransport *t) { (void)t; return true; }
static bool transport_close(struct uxrCustomTransport *t) { (void)t; return true; }
static size_t transport_write(struct uxrCustomTransport *t, const uint8_t *buf, size_t len, uint8_t *err) {
  (void)t; (void)buf; (void)err; return len;
}
static size_t transport_read(struct uxrCustomTransport *t, uint8_t *buf, size_t len, int timeout, uint8_t *err) {
  (void)t; (void)buf; (void)len; (void)timeout; (void)err; return 0;
}

/* -- the node --------------------------------------------------------------------------------- */
int main(void) {
  rmw_uros_set_custom_transport(true, NULL, transport_open, transport_close, transport_write, transport_read);

  rcl_allocator_t allocator = rcl_get_default_allocator();
  rclc_support_t support;
  if (rclc_support_init(&support, 0, NULL, &allocator) != RCL_RET_OK) {
    return 1;
  }
  rcl_node_t node;
  rclc_node_init_default(&node, "uros_example", "", &support);
  rcl_publisher_t publisher;
  rclc_publisher_init_default(&publisher, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32), "counter");

  std_msgs__msg__Int32 msg = {.data = 0};
  for (;;) {
    if (rcl_publish(&publisher, &msg, NULL) != RCL_RET_OK) {
      continue; /* agent not reachable yet: a real board would back off or reconnect here */
    }
    msg.data++;
  }
}
