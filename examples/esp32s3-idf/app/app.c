/* Seed 000's micro-ROS node (the ESP32-S3 LED): publishes the LED's colour as demo_interfaces/msg/Hsb
 * on "state/led/hsb" from a timer (every 5000 ms, as the seed's "LED State Message Interval") and
 * takes new colours from "command/led/hsb". One appMain for both places it runs:
 * - on the ESP32-S3 (ESP-IDF, ../main/main.c joins Wi-Fi and starts it as a FreeRTOS task): UDP to
 *   the agent set in `idf.py menuconfig`; it runs for ever;
 * - in `uros probe --app examples/esp32s3-idf/app` (a Cortex-M7 in QEMU, the board's serial link):
 *   -D HSB_EXIT_AFTER=N ends the run with exit(0) once N commands were applied and the state that
 *   followed each was published (exit 2 if they did not come within HSB_CHECK_MS);
 *   -D HSB_STATE_PERIOD_MS=200 shortens the timer; -D HSB_LOOPBACK makes the node's own state its
 *   command (the agent routes state/led/hsb back to it), so it checks itself without a ROS 2 peer. */
#include <demo_interfaces/msg/hsb.h>
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <rcutils/time.h>
#include <rmw_microros/rmw_microros.h>
#include <stdio.h>
#include <stdlib.h>

#ifdef ESP_PLATFORM
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"
#include "sdkconfig.h"
#define HSB_NODE_NAME CONFIG_UROS_NODE_NAME
#define HSB_STATE_PERIOD_MS CONFIG_UROS_STATE_PERIOD_MS
#define HSB_ABORT() vTaskDelete(NULL)
#define HSB_PAUSE() vTaskDelay(pdMS_TO_TICKS(10))
#else
#define HSB_ABORT() exit(1)
#define HSB_PAUSE()
#endif

#ifndef HSB_NODE_NAME
#define HSB_NODE_NAME "microros_demo"
#endif
#ifndef HSB_STATE_PERIOD_MS
#define HSB_STATE_PERIOD_MS 5000
#endif
#ifndef HSB_EXIT_AFTER
#define HSB_EXIT_AFTER 0 /* 0: run for ever, as on the board */
#endif
#ifndef HSB_CHECK_MS
#define HSB_CHECK_MS 30000
#endif
#ifdef HSB_LOOPBACK
#define HSB_COMMAND_TOPIC "state/led/hsb"
#else
#define HSB_COMMAND_TOPIC "command/led/hsb"
#endif

/* A failed micro-ROS call ends the node, with a line naming the call. */
#define RCCHECK(call)                                                                   \
  do {                                                                                  \
    rcl_ret_t rc_ = (call);                                                             \
    if (rc_ != RCL_RET_OK) {                                                            \
      printf("microros_demo: %s failed with %d (line %d)\n", #call, (int)rc_, __LINE__); \
      HSB_ABORT();                                                                      \
    }                                                                                   \
  } while (0)
#define RCSOFTCHECK(call)                                                               \
  do {                                                                                  \
    rcl_ret_t rc_ = (call);                                                             \
    if (rc_ != RCL_RET_OK) {                                                            \
      printf("microros_demo: %s failed with %d\n", #call, (int)rc_);                    \
    }                                                                                   \
  } while (0)

static rcl_publisher_t state_publisher;
static rcl_subscription_t command_subscription;
static demo_interfaces__msg__Hsb state = {.hue = 30, .saturation = 100, .brightness = 50};
static demo_interfaces__msg__Hsb command;
static int commands_applied, states_published_after;

static void on_state_timer(rcl_timer_t *timer, int64_t last_call_time) {
  (void)last_call_time;
  if (timer != NULL) {
    RCSOFTCHECK(rcl_publish(&state_publisher, &state, NULL));
    if (commands_applied > 0) states_published_after = commands_applied;
  }
}

static void on_command(const void *message) {
  const demo_interfaces__msg__Hsb *hsb = message;
  state.hue = hsb->hue % 360;
  state.saturation = hsb->saturation > 100 ? 100 : hsb->saturation;
  state.brightness = hsb->brightness > 100 ? 100 : hsb->brightness;
  commands_applied++;
  /* A real board drives its LED strip here (led_strip component, RMT). */
  printf("microros_demo: LED now HSB %u,%u,%u\n", state.hue, state.saturation, state.brightness);
}

static int64_t uptime_ms(void) {
  rcutils_time_point_value_t ns = 0;
  return rcutils_steady_time_now(&ns) == RCUTILS_RET_OK ? RCUTILS_NS_TO_MS(ns) : 0;
}

void appMain(void *arg) {
  (void)arg;
  rcl_allocator_t allocator = rcl_get_default_allocator();
  rcl_init_options_t init_options = rcl_get_zero_initialized_init_options();
  RCCHECK(rcl_init_options_init(&init_options, allocator));
#ifdef CONFIG_UROS_AGENT_IP
  rmw_init_options_t *rmw_options = rcl_init_options_get_rmw_init_options(&init_options);
  RCCHECK(rmw_uros_options_set_udp_address(CONFIG_UROS_AGENT_IP, CONFIG_UROS_AGENT_PORT, rmw_options));
#endif

  rclc_support_t support;
  RCCHECK(rclc_support_init_with_options(&support, 0, NULL, &init_options, &allocator));
  rcl_node_t node;
  RCCHECK(rclc_node_init_default(&node, HSB_NODE_NAME, "", &support));

  const rosidl_message_type_support_t *hsb = ROSIDL_GET_MSG_TYPE_SUPPORT(demo_interfaces, msg, Hsb);
  RCCHECK(rclc_publisher_init_default(&state_publisher, &node, hsb, "state/led/hsb"));
  printf("microros_demo: Created publisher state/led/hsb.\n");
  rcl_timer_t timer;
  RCCHECK(rclc_timer_init_default(&timer, &support, RCL_MS_TO_NS(HSB_STATE_PERIOD_MS), on_state_timer));
  printf("microros_demo: Created timer with timeout %d ms.\n", HSB_STATE_PERIOD_MS);
  RCCHECK(rclc_subscription_init_default(&command_subscription, &node, hsb, HSB_COMMAND_TOPIC));
  printf("microros_demo: Created subscriber %s.\n", HSB_COMMAND_TOPIC);

  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  RCCHECK(rclc_executor_init(&executor, &support.context, 2, &allocator));
  RCCHECK(rclc_executor_add_timer(&executor, &timer));
  RCCHECK(rclc_executor_add_subscription(&executor, &command_subscription, &command, on_command, ON_NEW_DATA));
  int64_t start = uptime_ms();
  for (;;) {
    rclc_executor_spin_some(&executor, RCL_MS_TO_NS(100));
    HSB_PAUSE();
    if (HSB_EXIT_AFTER > 0 && states_published_after >= HSB_EXIT_AFTER) {
      printf("microros_demo: PASS %d commands applied, the state followed\n", commands_applied);
      exit(0);
    }
    if (HSB_EXIT_AFTER > 0 && uptime_ms() - start > HSB_CHECK_MS) {
      printf("microros_demo: FAIL %d of %d commands came in %d ms\n", commands_applied, HSB_EXIT_AFTER, HSB_CHECK_MS);
      exit(2);
    }
  }
}
