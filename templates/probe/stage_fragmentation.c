/* uros probe, stage fragmentation: a std_msgs/String of 1.5 x the transport MTU on a reliable
 * publisher must come back whole through the agent (the XRCE-DDS client fragments it over the reliable
 * stream; the agent reassembles it, and fragments it again towards the firmware's subscription).
 *
 * A message over MTU x stream history is another matter (micro-ROS-Agent#143, rmw_microxrcedds#247):
 * the client still sends it (it flushes the stream while it writes), but a micro-ROS subscription
 * cannot take it: its reliable input stream holds `history` fragments, and rmw_microxrcedds copies
 * a sample into a static buffer of MTU x history bytes without checking (on_topic in callbacks.c): on
 * this library the firmware hung when one arrived. So the probe never lets one reach a subscription:
 * it drops its subscription, sends one, and names the colcon.meta options that carry such messages.
 * A library whose input streams cannot take even 1.5 x MTU fails the stage from its config.h.
 * Sizes as uros_build/output/msgsize.py counts them (each fragment 8 bytes of headers, the sample 8). */
#include <rcl/error_handling.h>
#include <rmw_microxrcedds_c/config.h>
#include <std_msgs/msg/string.h>
#include <stdio.h>
#include <string.h>

#include "probe.h"
#include "stages.h"

#define MTU RMW_UXRCE_MAX_TRANSPORT_MTU
#define HISTORY RMW_UXRCE_STREAM_HISTORY_INPUT
#define RELIABLE_MAX (HISTORY * (MTU - 8) - 8) /* the largest sample a reliable input stream takes */
#define CDR(chars) ((chars) + 5)                /* a string's CDR size: length, characters, NUL */
#define LARGE (MTU * 3 / 2)
#define TOO_LARGE (RELIABLE_MAX + 64)
#if UROS_PROBE_UDP /* over UDP (net/): the library's UDP transport's MTU */
#define MTU_OPTION "microxrcedds_client.UCLIENT_UDP_TRANSPORT_MTU"
#else
#define MTU_OPTION "microxrcedds_client.UCLIENT_CUSTOM_TRANSPORT_MTU"
#endif
#define RAISE                                                                                   \
  "raise rmw_microxrcedds.RMW_UXRCE_STREAM_HISTORY (RMW_UXRCE_STREAM_HISTORY_INPUT where set) or " MTU_OPTION

static char outgoing_text[TOO_LARGE + 1];
static char incoming_text[LARGE + 64];
static size_t arrived;  /* the length of the last string that came back, */
static bool arrived_ok; /* and whether it was the one sent, byte for byte */

static void on_string(const void *message) {
  const std_msgs__msg__String *in = message;
  arrived = in->data.size;
  arrived_ok = in->data.size <= LARGE && memcmp(in->data.data, outgoing_text, in->data.size) == 0;
}

static std_msgs__msg__String text_of(size_t length) {
  for (size_t i = 0; i < length; i++) outgoing_text[i] = (char)('a' + (i * 7 + length) % 26);
  outgoing_text[length] = '\0';
  return (std_msgs__msg__String){.data = {.data = outgoing_text, .size = length, .capacity = length + 1}};
}

/* Publish LARGE characters every 300 ms until they come back or `ms` passed; whether they did, whole. */
static bool large_comes_back(rcl_publisher_t *publisher, rclc_executor_t *executor, uint32_t ms) {
  std_msgs__msg__String outgoing = text_of(LARGE);
  arrived = 0;
  arrived_ok = false;
  uint32_t begin = probe_millis();
  while (probe_millis() - begin < ms) {
    if (rcl_publish(publisher, &outgoing, NULL) != RCL_RET_OK) rcl_reset_error();
    uint32_t sent = probe_millis();
    while (probe_millis() - sent < 300u && arrived == 0) rclc_executor_spin_some(executor, RCL_MS_TO_NS(5));
    if (arrived != 0) return arrived == LARGE && arrived_ok;
  }
  return false;
}

int stage_fragmentation(probe_session_t *session) {
  if (CDR(LARGE) > RELIABLE_MAX) {
    probe_stage("fragmentation", "fail",
                "a %d-byte std_msgs/String (1.5 x MTU %d) is more than this library's reliable streams carry "
                "(MTU x history = %d x %d: %d B a sample): %s in colcon.meta",
                CDR(LARGE), MTU, MTU, HISTORY, RELIABLE_MAX, RAISE);
    return PROBE_FRAGMENTATION;
  }
  const rosidl_message_type_support_t *type = ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, String);
  rcl_publisher_t publisher = rcl_get_zero_initialized_publisher();
  rcl_subscription_t subscription = rcl_get_zero_initialized_subscription();
  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  std_msgs__msg__String incoming = {.data = {.data = incoming_text, .size = 0, .capacity = sizeof incoming_text}};
  int status = PROBE_FRAGMENTATION;
  if (rclc_publisher_init_default(&publisher, &session->node, type, "uros_probe_large") != RCL_RET_OK ||
      rclc_subscription_init_default(&subscription, &session->node, type, "uros_probe_large") != RCL_RET_OK ||
      rclc_executor_init(&executor, &session->support.context, 1, &session->allocator) != RCL_RET_OK ||
      rclc_executor_add_subscription(&executor, &subscription, &incoming, on_string, ON_NEW_DATA) != RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("fragmentation", "fail", "a reliable std_msgs/String publisher and subscription could not be created");
  } else if (probe_link_publisher(&publisher), !large_comes_back(&publisher, &executor, 3000u)) {
    probe_stage("fragmentation", "fail",
                "a %d-byte std_msgs/String (1.5 x MTU %d) did not come back whole on a reliable stream: %s "
                "in colcon.meta",
                CDR(LARGE), MTU, RAISE);
  } else {
    (void)rclc_executor_fini(&executor);
    probe_ignore(rcl_subscription_fini(&subscription, &session->node)); /* none may receive what follows */
#ifdef PROBE_LOSSY_LINK
    /* uros probe --link: over UDP at 10 % loss and 100-300 ms, the client flushing a sample its
     * output history cannot hold while it writes it waited for acknowledgements that were lost, gave
     * up mid-sample ("could not be sent") and the next stage hung: not sent on a lossy link */
    probe_stage("fragmentation", "pass",
                "%d B (1.5 x MTU %d) came back whole; over %d B (MTU x history %d x %d) not sent on a lossy link "
                "(uros probe --link: it wedged the reliable stream)",
                CDR(LARGE), MTU, RELIABLE_MAX, MTU, HISTORY);
#else
    std_msgs__msg__String too_large = text_of(TOO_LARGE - 5);
    bool sent = rcl_publish(&publisher, &too_large, NULL) == RCL_RET_OK;
    rcl_reset_error();
    printf("uros-probe: a %d-byte std_msgs/String, over MTU x history (%d x %d: %d B a sample), %s, and no "
           "subscription of this library can take it: to carry such messages %s in colcon.meta\n",
           TOO_LARGE, MTU, HISTORY, RELIABLE_MAX, sent ? "was sent" : "could not be sent", RAISE);
    probe_stage("fragmentation", "pass",
                "%d B (1.5 x MTU %d) came back whole; over %d B (MTU x history %d x %d) no subscription takes: %s",
                CDR(LARGE), MTU, RELIABLE_MAX, MTU, HISTORY, RAISE);
#endif
    status = 0;
  }
  (void)rclc_executor_fini(&executor);
  probe_ignore(rcl_subscription_fini(&subscription, &session->node));
  probe_ignore(rcl_publisher_fini(&publisher, &session->node));
  return status;
}
