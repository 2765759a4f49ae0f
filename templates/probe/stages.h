/* uros probe: what main.c, session.c and the stage files share. Each stage prints one line,
 *   uros-probe: stage <name> pass|fail|skip <detail>
 * (uros_build/run/stages.py reads them), and returns 0 or its own exit status. */
#ifndef UROS_PROBE_STAGES_H
#define UROS_PROBE_STAGES_H
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <std_msgs/msg/int32.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

/* The exit statuses (uros_build/run/machines.py: VERDICTS). */
enum {
  PROBE_NO_AGENT = 2,
  PROBE_NO_SESSION = 3,
  PROBE_NO_ENTITY = 4,
  PROBE_SAMPLES_LOST = 5,
  PROBE_TEARDOWN = 6,
  PROBE_SERVICE = 7,
  PROBE_TIME = 8,
  /* 9: the FreeRTOS variant's two-task stage (freertos/two_tasks.c) */
  PROBE_RESTART = 10,
  PROBE_FRAGMENTATION = 11,
  PROBE_PARAMETERS = 12,
  PROBE_ACTION = 13,
  PROBE_BEST_EFFORT = 14,
};

/* A session with one node: what every stage works in. */
typedef struct {
  rcl_allocator_t allocator;
  rclc_support_t support;
  rcl_node_t node;
} probe_session_t;

/* An Int32 publisher and subscription on one topic, the agent routing samples back. */
typedef struct {
  rcl_publisher_t publisher;
  rcl_subscription_t subscription;
  rclc_executor_t executor;
  std_msgs__msg__Int32 incoming;
} probe_loop_t;

/* A call that must succeed, else a FAIL line and `return status` (main.c, session.c). */
#define EXPECT(call, status, what)                                                \
  do {                                                                            \
    rcl_ret_t ret_ = (call);                                                      \
    if (ret_ != RCL_RET_OK) {                                                     \
      printf("uros-probe: FAIL %s (%s returned %d)\n", what, #call, (int)ret_);   \
      rcl_reset_error();                                                          \
      return status;                                                              \
    }                                                                             \
  } while (0)

/* A clean-up whose failure changes nothing (the error is cleared for the next call). */
static inline void probe_ignore(rcl_ret_t ret) {
  if (ret != RCL_RET_OK) rcl_reset_error();
}

/* session.c: what the stages share */
void probe_stage(const char *name, const char *result, const char *format, ...)
    __attribute__((format(printf, 3, 4)));
void probe_spin_for(rclc_executor_t *executor, uint32_t ms);
/* uros probe --link: a session's entities and a reliable publisher wait longer for the agent */
void probe_link_session(rclc_support_t *support);
void probe_link_publisher(rcl_publisher_t *publisher);

int probe_session_open(probe_session_t *session);
int probe_loop_open(probe_loop_t *loop, probe_session_t *session);
int probe_loop_close(probe_loop_t *loop, probe_session_t *session); /* 0, or PROBE_TEARDOWN */
/* Publish every 50 ms until `want` samples came back or `ms` passed; how many came back. */
int probe_loop_samples(probe_loop_t *loop, int want, uint32_t ms, int *sent, uint32_t *took);

/* the stages (stage_*.c), sequenced by main.c */
int stage_limits(probe_session_t *session, probe_loop_t *loop);
int stage_service(probe_session_t *session);
int stage_parameters(probe_session_t *session);
int stage_action(probe_session_t *session);
int stage_time(void);
int stage_best_effort(probe_session_t *session);
int stage_fragmentation(probe_session_t *session);
int stage_restart(probe_session_t *session, probe_loop_t *loop);
#endif
