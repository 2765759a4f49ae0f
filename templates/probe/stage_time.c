/* uros probe, stage time: rmw_uros_sync_session asks the agent for its clock (XRCE TIMESTAMP), and
 * rmw_uros_epoch_millis() then gives the host's epoch from the firmware's own clock. The firmware
 * prints the epoch the moment it has it; uros, watching the console live, compares it with the host
 * time the line appeared (uros_build/run/stages.py: within 1 s). One request is not retried by the
 * client, so on a link that loses a message in ten it failed about one run in three (issue 40): the
 * stage asks again, PROBE_TIME_ATTEMPTS times at most, and says how many it took. */
#include <rmw_microros/rmw_microros.h>
#include <stdio.h>

#include "probe.h"
#include "stages.h"

#ifndef PROBE_TIME_ATTEMPTS
#define PROBE_TIME_ATTEMPTS 5
#endif
#define PROBE_TIME_WAIT_MS 1000

int stage_time(void) {
  uint32_t begin = probe_millis();
  int attempts = 0;
  bool synced = false;
  while (!synced && attempts < PROBE_TIME_ATTEMPTS) {
    attempts++;
    synced = rmw_uros_sync_session(PROBE_TIME_WAIT_MS) == RMW_RET_OK && rmw_uros_epoch_synchronized();
  }
  if (!synced) {
    probe_stage("time", "fail", "rmw_uros_sync_session: no answer from the agent in %d attempts of %d ms",
                attempts, PROBE_TIME_WAIT_MS);
    return PROBE_TIME;
  }
  uint32_t took = probe_millis() - begin;
  int64_t epoch = rmw_uros_epoch_millis();
  /* newlib-nano's printf has no %lld: seconds and milliseconds apart */
  probe_stage("time", "pass", "epoch %lu.%03lu s (synced in %lu ms, %d attempt%s)", (unsigned long)(epoch / 1000),
              (unsigned long)(epoch % 1000), (unsigned long)took, attempts, attempts == 1 ? "" : "s");
  return 0;
}
