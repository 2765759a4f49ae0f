/* uros probe, stage best_effort (with `uros probe --link`): Int32 samples on a best-effort publisher,
 * one every PROBE_BEST_EFFORT_PERIOD_MS until the first came back, then PROBE_BEST_EFFORT_SAMPLES
 * more, to the firmware's own best-effort subscription through the agent; a best-effort stream
 * does not retransmit, so what the
 * link loses stays lost. The firmware's line says what it published and counted back; uros's verdict
 * and figures are the relay's own counts of the samples each way (uros_build/run/relay.py), never
 * this line alone (uros_build/run/stages.py judge_best_effort). */
#include <rcl/error_handling.h>
#include <stdio.h>

#include "probe.h"
#include "stages.h"

#ifndef PROBE_BEST_EFFORT_SAMPLES
#define PROBE_BEST_EFFORT_SAMPLES 50
#endif
#define PROBE_BEST_EFFORT_PERIOD_MS 40u
#define PROBE_BEST_EFFORT_DRAIN_MS 2000u /* for the last samples to come back over a slow link */
#define PROBE_BEST_EFFORT_READY_MS 15000u

static int counted;
static void on_best_effort(const void *message) {
  (void)message;
  counted++;
}

int stage_best_effort(probe_session_t *session) {
  const rosidl_message_type_support_t *int32 = ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32);
  rcl_publisher_t publisher = rcl_get_zero_initialized_publisher();
  rcl_subscription_t subscription = rcl_get_zero_initialized_subscription();
  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  std_msgs__msg__Int32 incoming;
  std_msgs__msg__Int32__init(&incoming);
  if (rclc_publisher_init_best_effort(&publisher, &session->node, int32, "uros_probe_best_effort") != RCL_RET_OK ||
      rclc_subscription_init_best_effort(&subscription, &session->node, int32, "uros_probe_best_effort") !=
          RCL_RET_OK ||
      rclc_executor_init(&executor, &session->support.context, 1, &session->allocator) != RCL_RET_OK ||
      rclc_executor_add_subscription(&executor, &subscription, &incoming, on_best_effort, ON_NEW_DATA) !=
          RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("best_effort", "fail", "a best-effort publisher and subscription could not be created");
    (void)rclc_executor_fini(&executor);
    probe_ignore(rcl_subscription_fini(&subscription, &session->node));
    probe_ignore(rcl_publisher_fini(&publisher, &session->node));
    return PROBE_BEST_EFFORT;
  }
  /* until the first sample comes back, at most PROBE_BEST_EFFORT_READY_MS: the agent sends samples
   * only once the subscription's request for data (READ_DATA, on the reliable stream; rmw does not
   * wait for its answer) reached it, and on a lossy link that took 13 s once (MicroXRCEAgent's log,
   * UDP, seed 8); waiting a fixed 500 ms or 3 s, the agent sent 0 or 5 of 44 back in some runs */
  counted = 0;
  int published = 0, before = 0;
  std_msgs__msg__Int32 outgoing = {.data = 5000};
  uint32_t begin = probe_millis();
  while (counted == 0 && probe_millis() - begin < PROBE_BEST_EFFORT_READY_MS) {
    if (rcl_publish(&publisher, &outgoing, NULL) == RCL_RET_OK) published++;
    rcl_reset_error();
    outgoing.data++;
    probe_spin_for(&executor, PROBE_BEST_EFFORT_PERIOD_MS);
  }
  before = published;
  for (int i = 0; i < PROBE_BEST_EFFORT_SAMPLES; i++) {
    if (rcl_publish(&publisher, &outgoing, NULL) == RCL_RET_OK) published++;
    rcl_reset_error();
    outgoing.data++;
    probe_spin_for(&executor, PROBE_BEST_EFFORT_PERIOD_MS);
  }
  probe_spin_for(&executor, PROBE_BEST_EFFORT_DRAIN_MS);
  uint32_t took = probe_millis() - begin;
  (void)rclc_executor_fini(&executor);
  probe_ignore(rcl_subscription_fini(&subscription, &session->node));
  probe_ignore(rcl_publisher_fini(&publisher, &session->node));
  probe_stage("best_effort", published > 0 ? "pass" : "fail",
              "published %d, counted %d back in %lu ms (%d before the first came back)", published, counted,
              (unsigned long)took, before);
  return published > 0 ? 0 : PROBE_BEST_EFFORT;
}
