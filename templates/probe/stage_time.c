/* uros probe, stage time: rmw_uros_sync_session asks the agent for its clock (XRCE TIMESTAMP), and
 * rmw_uros_epoch_millis() then gives the host's epoch from the firmware's own clock. The firmware
 * prints the epoch the moment it has it; uros, watching the console live, compares it with the host
 * time the line appeared (uros_build/run/stages.py: within 1 s). */
#include <rmw_microros/rmw_microros.h>
#include <stdio.h>

#include "probe.h"
#include "stages.h"

int stage_time(void) {
  uint32_t begin = probe_millis();
  if (rmw_uros_sync_session(1000) != RMW_RET_OK || !rmw_uros_epoch_synchronized()) {
    probe_stage("time", "fail", "rmw_uros_sync_session: no answer from the agent in 1000 ms");
    return PROBE_TIME;
  }
  uint32_t took = probe_millis() - begin;
  int64_t epoch = rmw_uros_epoch_millis();
  /* newlib-nano's printf has no %lld: seconds and milliseconds apart */
  probe_stage("time", "pass", "epoch %lu.%03lu s (synced in %lu ms)", (unsigned long)(epoch / 1000),
              (unsigned long)(epoch % 1000), (unsigned long)took);
  return 0;
}
