/* uros probe, stage action: an rclc action server of example_interfaces' Fibonacci ("uros_probe_fibonacci")
 * and the firmware's own action client of it, through the agent without a peer: the client sends a goal
 * (order 5), the server accepts it, publishes feedback and sends the result [0, 1, 1, 2, 3]; the client
 * sees the acceptance, the feedback and the result. An action server takes 3 services and 2 publishers
 * (goal, cancel, result; feedback, status: rcl_action's action_server.c, humble) and its goal-expiry
 * timer's guard condition; the client 3 clients and 2 subscriptions (action_client.c). A library
 * without that room, or without the type, skips the stage and says why, never `pass`.
 * The client is rcl_action's, not rclc's: rclc's (humble, iron, rolling) writes each goal id with two
 * 64-bit stores into a byte array at offset 9 of its goal handle (action_client.c, set_uuid), which GCC
 * compiles to STRD, and STRD to an address that is not a multiple of 4 is a UsageFault on every
 * Cortex-M: tried here, rclc_action_send_goal_request hard-faulted (CFSR 0x01000000, UNALIGNED) on
 * cortex-m7. The goal is sent again every 500 ms until accepted (the agent's DDS endpoints match a
 * moment after creation), for at most PROBE_ACTION_MS in all. */
#include <rcl/error_handling.h>
#include <rmw_microxrcedds_c/config.h>
#include <stdio.h>
#include <string.h>

#include "probe.h"
#include "stages.h"

#define PROBE_ACTION_MS 8000u
#define PROBE_ACTION_ORDER 5
#define PROBE_ACTION_GOALS 4 /* goal handles on each side: a goal sent again may be accepted twice */

#if __has_include(<example_interfaces/action/fibonacci.h>) && __has_include(<rclc/action_server.h>)
#include <example_interfaces/action/fibonacci.h>
#include <rcl_action/rcl_action.h>
#include <rclc/action_server.h>

#define ROOM                                                                                              \
  (RMW_UXRCE_MAX_SERVICES >= 3 && RMW_UXRCE_MAX_CLIENTS >= 3 && RMW_UXRCE_MAX_PUBLISHERS >= 2 && \
   RMW_UXRCE_MAX_SUBSCRIPTIONS >= 2 && RMW_UXRCE_MAX_GUARD_CONDITION >= 1)

#if ROOM
typedef example_interfaces__action__Fibonacci_SendGoal_Request goal_request_t;

static rclc_action_goal_handle_t *serving[PROBE_ACTION_GOALS];
static goal_request_t goal; /* the client's: the same goal id each time it is sent again */
static int served, accepted, feedbacks, results;
static int32_t result_sequence[PROBE_ACTION_ORDER + 1];
static size_t result_size;
static int8_t result_status;

/* server side */
static rcl_ret_t on_goal(rclc_action_goal_handle_t *handle, void *context) {
  (void)context;
  if (served >= PROBE_ACTION_GOALS) return RCL_RET_ACTION_GOAL_REJECTED;
  serving[served++] = handle;
  return RCL_RET_ACTION_GOAL_ACCEPTED;
}

static bool on_cancel(rclc_action_goal_handle_t *handle, void *context) {
  (void)handle;
  (void)context;
  return false;
}

/* The server's work for each accepted goal: feedback [0, 1] three times, then the result (retried
 * until the client's result request came: RCLC_RET_ACTION_WAIT_RESULT_REQUEST before). */
static void serve(int *fed, bool *done) {
  static int32_t sequence[PROBE_ACTION_ORDER] = {0, 1, 1, 2, 3};
  for (int i = 0; i < served; i++) {
    if (done[i]) continue;
    if (fed[i] < 3) {
      example_interfaces__action__Fibonacci_FeedbackMessage feedback;
      memset(&feedback, 0, sizeof(feedback));
      feedback.feedback.sequence = (rosidl_runtime_c__int32__Sequence){.data = sequence, .size = 2, .capacity = 2};
      if (rclc_action_publish_feedback(serving[i], &feedback) == RCL_RET_OK) fed[i]++;
      rcl_reset_error();
      continue;
    }
    example_interfaces__action__Fibonacci_GetResult_Response response;
    memset(&response, 0, sizeof(response));
    response.result.sequence =
        (rosidl_runtime_c__int32__Sequence){.data = sequence, .size = PROBE_ACTION_ORDER, .capacity = PROBE_ACTION_ORDER};
    if (rclc_action_send_result(serving[i], GOAL_STATE_SUCCEEDED, &response) == RCL_RET_OK) done[i] = true;
    rcl_reset_error();
  }
}

/* The client's side, rcl_action's calls polled while the executor (the server's) spins: rmw_microxrcedds
 * keeps every reply and sample the session brings, whoever waits on it. */
static void take(rcl_action_client_t *client, int64_t *result_asked) {
  static int32_t feedback_data[PROBE_ACTION_ORDER + 1], result_data[PROBE_ACTION_ORDER + 1];
  static action_msgs__msg__GoalStatus statuses[PROBE_ACTION_GOALS];
  rmw_request_id_t header;
  example_interfaces__action__Fibonacci_SendGoal_Response answer;
  memset(&answer, 0, sizeof(answer));
  if (rcl_action_take_goal_response(client, &header, &answer) == RCL_RET_OK && answer.accepted && accepted++ == 0) {
    example_interfaces__action__Fibonacci_GetResult_Request ask;
    memcpy(ask.goal_id.uuid, goal.goal_id.uuid, sizeof(ask.goal_id.uuid));
    if (rcl_action_send_result_request(client, &ask, result_asked) != RCL_RET_OK) *result_asked = -1;
  }
  example_interfaces__action__Fibonacci_FeedbackMessage feedback;
  memset(&feedback, 0, sizeof(feedback));
  feedback.feedback.sequence =
      (rosidl_runtime_c__int32__Sequence){.data = feedback_data, .size = 0, .capacity = PROBE_ACTION_ORDER + 1};
  while (rcl_action_take_feedback(client, &feedback) == RCL_RET_OK) feedbacks++;
  /* the status messages are taken and dropped: left, they would hold rmw's input buffers */
  action_msgs__msg__GoalStatusArray status;
  memset(&status, 0, sizeof(status));
  status.status_list =
      (action_msgs__msg__GoalStatus__Sequence){.data = statuses, .size = 0, .capacity = PROBE_ACTION_GOALS};
  while (rcl_action_take_status(client, &status) == RCL_RET_OK) {
  }
  example_interfaces__action__Fibonacci_GetResult_Response result;
  memset(&result, 0, sizeof(result));
  result.result.sequence =
      (rosidl_runtime_c__int32__Sequence){.data = result_data, .size = 0, .capacity = PROBE_ACTION_ORDER + 1};
  if (rcl_action_take_result_response(client, &header, &result) == RCL_RET_OK && results++ == 0) {
    result_status = result.status;
    result_size = result.result.sequence.size <= PROBE_ACTION_ORDER ? result.result.sequence.size : 0;
    memcpy(result_sequence, result.result.sequence.data, result_size * sizeof(int32_t));
  }
  rcl_reset_error();
}

static const char *run(rclc_executor_t *executor, rcl_action_client_t *client, uint32_t *took) {
  memset(&goal, 0, sizeof(goal));
  goal.goal.order = PROBE_ACTION_ORDER;
  for (size_t i = 0; i < sizeof(goal.goal_id.uuid); i++) goal.goal_id.uuid[i] = (uint8_t)(0x51 + i);
  int fed[PROBE_ACTION_GOALS] = {0};
  bool done[PROBE_ACTION_GOALS] = {false};
  uint32_t begin = probe_millis(), sent_at = 0;
  bool sent = false;
  int64_t sequence, result_asked = 0;
  while (results == 0 && probe_millis() - begin < PROBE_ACTION_MS) {
    if (accepted == 0 && (!sent || probe_millis() - sent_at >= 500u)) {
      if (rcl_action_send_goal_request(client, &goal, &sequence) != RCL_RET_OK) rcl_reset_error();
      sent = true;
      sent_at = probe_millis();
    }
    rclc_executor_spin_some(executor, RCL_MS_TO_NS(5));
    serve(fed, done);
    take(client, &result_asked);
  }
  *took = probe_millis() - begin;
  if (accepted == 0) return served == 0 ? "no goal reached the server" : "the client saw no acceptance";
  if (result_asked < 0) return "the result request could not be sent";
  if (results == 0) return feedbacks == 0 ? "no feedback and no result came back" : "no result came back";
  return NULL;
}
#endif

int stage_action(probe_session_t *session) {
#if !ROOM
  (void)session;
  probe_stage("action", "skip",
              "an action server and client take 3 services, 3 clients, 2 publishers, 2 subscriptions and a guard "
              "condition; the library has RMW_UXRCE_MAX_SERVICES=%d, _CLIENTS=%d, _PUBLISHERS=%d, _SUBSCRIPTIONS=%d, "
              "_GUARD_CONDITION=%d (uros build --set rmw_microxrcedds.RMW_UXRCE_MAX_...)",
              RMW_UXRCE_MAX_SERVICES, RMW_UXRCE_MAX_CLIENTS, RMW_UXRCE_MAX_PUBLISHERS, RMW_UXRCE_MAX_SUBSCRIPTIONS,
              RMW_UXRCE_MAX_GUARD_CONDITION);
  return 0;
#else
  const rosidl_action_type_support_t *type = ROSIDL_GET_ACTION_TYPE_SUPPORT(example_interfaces, Fibonacci);
  static rclc_action_server_t server;
  rcl_ret_t ret = rclc_action_server_init_default(&server, &session->node, &session->support, type,
                                                  "uros_probe_fibonacci");
  if (ret != RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("action", "fail",
                "the Fibonacci action server could not be created (rclc_action_server_init_default returned %d; it "
                "takes 3 services, 2 publishers and a guard condition)",
                (int)ret);
    return PROBE_ACTION;
  }
  rcl_action_client_t client = rcl_action_get_zero_initialized_client();
  rcl_action_client_options_t options = rcl_action_client_get_default_options();
  ret = rcl_action_client_init(&client, &session->node, type, "uros_probe_fibonacci", &options);
  if (ret != RCL_RET_OK) {
    rcl_reset_error();
    probe_ignore(rclc_action_server_fini(&server, &session->node));
    probe_stage("action", "fail",
                "the Fibonacci action client could not be created (rcl_action_client_init returned %d; it takes 3 "
                "clients and 2 subscriptions)",
                (int)ret);
    return PROBE_ACTION;
  }
  static goal_request_t requests[PROBE_ACTION_GOALS];
  served = accepted = feedbacks = results = 0;
  result_status = 0;
  result_size = 0;
  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  int status = PROBE_ACTION;
  if (rclc_executor_init(&executor, &session->support.context, 1, &session->allocator) == RCL_RET_OK &&
      rclc_executor_add_action_server(&executor, &server, PROBE_ACTION_GOALS, requests, sizeof(goal_request_t),
                                      on_goal, on_cancel, NULL) == RCL_RET_OK) {
    uint32_t took = 0;
    const char *failed = run(&executor, &client, &took);
    bool right = result_status == GOAL_STATE_SUCCEEDED && result_size == PROBE_ACTION_ORDER &&
                 result_sequence[0] == 0 && result_sequence[4] == 3;
    if (failed == NULL && right && feedbacks > 0) {
      probe_stage("action", "pass",
                  "a Fibonacci goal (order %d) accepted, %d feedback and the result [0, 1, 1, 2, 3] through the agent "
                  "in %lu ms",
                  PROBE_ACTION_ORDER, feedbacks, (unsigned long)took);
      status = 0;
    } else if (failed == NULL) {
      probe_stage("action", "fail", "the result came back %s after %d feedback (status %d, %u values)",
                  right ? "right" : "wrong", feedbacks, (int)result_status, (unsigned)result_size);
    } else {
      probe_stage("action", "fail", "%s in %lu ms (%d goals reached the server, %d accepted, %d feedback)", failed,
                  (unsigned long)took, served, accepted, feedbacks);
    }
  } else {
    rcl_reset_error();
    probe_stage("action", "fail", "the executor could not take the action server");
  }
  (void)rclc_executor_fini(&executor);
  probe_ignore(rcl_action_client_fini(&client, &session->node));
  probe_ignore(rclc_action_server_fini(&server, &session->node));
  rcl_reset_error();
  return status;
#endif
}
#else
int stage_action(probe_session_t *session) {
  (void)session;
  probe_stage("action", "skip",
              "the library has no example_interfaces/action/Fibonacci (uros build --packages example_interfaces)");
  return 0;
}
#endif
