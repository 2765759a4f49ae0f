/* uros probe, stage restart: the agent goes away and comes back, and the node carries on. The
 * firmware asks uros to restart the agent (the line "uros-probe: restart the agent"); uros stops it
 * and, once the firmware says "agent lost", starts it again on the same serial link. The firmware
 * does what micro-ROS-demos' and micro_ros_stm32cubemx_utils' reconnection state machine does: once a
 * rmw_uros_ping_agent fails, destroy the entities without waiting for the agent (destroy-session
 * timeout 0), ping until the agent answers again, create the session, node, publisher and
 * subscription again, and publish until samples come back. The loop's entities are open on entry
 * (main.c opened them again for this stage) and on a pass. */
#include <rcl/error_handling.h>
#include <rmw_microros/rmw_microros.h>
#include <stdio.h>

#include "fleet.h"
#include "link.h"
#include "probe.h"
#include "stages.h"

#define PROBE_RESTART_GONE_MS 5000u  /* for the agent to go */
#define PROBE_RESTART_BACK_MS 10000u /* for it to answer again */
#define PROBE_RESTART_SAMPLES 5

int stage_restart(probe_session_t *session, probe_loop_t *loop) {
  printf("uros-probe: restart the agent\n");
  uint32_t asked = probe_millis();
  /* one of many boards: a missed ping is not a stopped agent (fleet.h) */
  for (int missed = 0; missed < probe_pings_lost();) {
    if (probe_ping(50, 1) != RMW_RET_OK) {
      missed++;
      continue;
    }
    missed = 0;
    if (probe_millis() - asked > probe_restart_gone_ms(PROBE_RESTART_GONE_MS)) {
      probe_stage("restart", "fail", "the agent still answered %lu ms after the firmware asked for a restart",
                  (unsigned long)probe_restart_gone_ms(PROBE_RESTART_GONE_MS));
      return PROBE_RESTART;
    }
    uint32_t pause = probe_millis();
    while (probe_millis() - pause < 50u) {
    }
  }
  uint32_t lost = probe_millis();
  printf("uros-probe: agent lost\n");
  /* destroy first: a ping through the old session goes unanswered by a new agent (it never knew the
   * session); without one, rmw_uros_ping_agent pings on the bare transport */
  rmw_context_t *context = rcl_context_get_rmw_context(&session->support.context);
  (void)rmw_uros_set_context_entity_destroy_session_timeout(context, 0);
  probe_ignore(rcl_publisher_fini(&loop->publisher, &session->node));
  probe_ignore(rcl_subscription_fini(&loop->subscription, &session->node));
  (void)rclc_executor_fini(&loop->executor);
  probe_ignore(rcl_node_fini(&session->node));
  (void)rclc_support_fini(&session->support);
  rcl_reset_error();
  while (probe_ping(100, 1) != RMW_RET_OK) {
    if (probe_millis() - lost > PROBE_RESTART_BACK_MS) {
      probe_stage("restart", "fail", "the agent did not answer again within %u ms", PROBE_RESTART_BACK_MS);
      return PROBE_RESTART;
    }
  }
  uint32_t found = probe_millis();
  printf("uros-probe: agent back after %lu ms\n", (unsigned long)(found - lost));
  int status = probe_session_open(session);
  if (status == 0) status = probe_loop_open(loop, session);
  if (status != 0) {
    probe_stage("restart", "fail", "the session and its entities could not be created again (exit %d)", status);
    return PROBE_RESTART;
  }
  uint32_t recreated = probe_millis();
  int sent;
  uint32_t took;
  int got = probe_loop_samples(loop, PROBE_RESTART_SAMPLES, 5000u, &sent, &took);
  if (got < PROBE_RESTART_SAMPLES) {
    probe_stage("restart", "fail", "entities created again, but %d of %d samples came back in %lu ms", got,
                PROBE_RESTART_SAMPLES, (unsigned long)took);
    return PROBE_RESTART;
  }
  uint32_t done = probe_millis();
  probe_stage("restart", "pass",
              "reconnected in %lu ms after the agent answered again (entities %lu ms, %d samples back %lu ms)",
              (unsigned long)(done - found), (unsigned long)(recreated - found), got, (unsigned long)took);
  return 0;
}
