/* uros probe, stage service: a service round trip through the agent. The firmware serves
 * example_interfaces/srv/AddTwoInts on "uros_probe_add" and calls it with its own client: the request
 * goes out to the agent, which routes it to the server (an XRCE replier), and the response back to
 * the client (a requester). A request is sent again every 250 ms until the answer comes (the agent's
 * DDS endpoints match a moment after creation), for at most PROBE_SERVICE_MS. Without the type in the
 * library the stage is skipped, and says why. */
#include <rcl/error_handling.h>
#include <rmw_microxrcedds_c/config.h>
#include <stdio.h>

#include "probe.h"
#include "stages.h"

#define PROBE_SERVICE_MS 5000u

#if __has_include(<example_interfaces/srv/add_two_ints.h>)
#include <example_interfaces/srv/add_two_ints.h>

static int64_t answer;
static bool answered;

static void on_request(const void *request, void *response) {
  const example_interfaces__srv__AddTwoInts_Request *in = request;
  example_interfaces__srv__AddTwoInts_Response *out = response;
  out->sum = in->a + in->b;
}

static void on_response(const void *response) {
  answer = ((const example_interfaces__srv__AddTwoInts_Response *)response)->sum;
  answered = true;
}

static int round_trip(rclc_executor_t *executor, rcl_client_t *client, uint32_t *took, int *sent) {
  example_interfaces__srv__AddTwoInts_Request request = {.a = 0, .b = 1000};
  uint32_t begin = probe_millis();
  *sent = 0;
  while (probe_millis() - begin < PROBE_SERVICE_MS) {
    request.a++; /* each request its own sum: a late answer to an earlier one is not taken */
    int64_t sequence;
    answered = false;
    if (rcl_send_request(client, &request, &sequence) != RCL_RET_OK) rcl_reset_error();
    (*sent)++;
    uint32_t asked = probe_millis();
    while (probe_millis() - asked < 250u && !(answered && answer == request.a + request.b)) {
      rclc_executor_spin_some(executor, RCL_MS_TO_NS(5));
    }
    if (answered && answer == request.a + request.b) {
      *took = probe_millis() - begin;
      return 1;
    }
  }
  *took = probe_millis() - begin;
  return 0;
}

int stage_service(probe_session_t *session) {
  const rosidl_service_type_support_t *type = ROSIDL_GET_SRV_TYPE_SUPPORT(example_interfaces, srv, AddTwoInts);
  rcl_service_t service = rcl_get_zero_initialized_service();
  rcl_ret_t ret = rclc_service_init_default(&service, &session->node, type, "uros_probe_add");
  if (ret != RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("service", "fail",
                "the AddTwoInts service could not be created (rclc_service_init_default returned %d; "
                "RMW_UXRCE_MAX_SERVICES=%d)",
                (int)ret, RMW_UXRCE_MAX_SERVICES);
    return PROBE_SERVICE;
  }
  rcl_client_t client = rcl_get_zero_initialized_client();
  ret = rclc_client_init_default(&client, &session->node, type, "uros_probe_add");
  if (ret != RCL_RET_OK) {
    rcl_reset_error();
    probe_ignore(rcl_service_fini(&service, &session->node));
    probe_stage("service", "fail",
                "the AddTwoInts client could not be created (rclc_client_init_default returned %d; "
                "RMW_UXRCE_MAX_CLIENTS=%d)",
                (int)ret, RMW_UXRCE_MAX_CLIENTS);
    return PROBE_SERVICE;
  }
  example_interfaces__srv__AddTwoInts_Request request_in;
  example_interfaces__srv__AddTwoInts_Response response_out, response_in;
  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  int status = PROBE_SERVICE;
  if (rclc_executor_init(&executor, &session->support.context, 2, &session->allocator) == RCL_RET_OK &&
      rclc_executor_add_service(&executor, &service, &request_in, &response_out, on_request) == RCL_RET_OK &&
      rclc_executor_add_client(&executor, &client, &response_in, on_response) == RCL_RET_OK) {
    uint32_t took;
    int sent;
    if (round_trip(&executor, &client, &took, &sent)) {
      probe_stage("service", "pass", "AddTwoInts answered %ld in %lu ms (%d requests sent)", (long)answer,
                  (unsigned long)took, sent);
      status = 0;
    } else {
      probe_stage("service", "fail", "no answer to %d AddTwoInts requests in %lu ms", sent, (unsigned long)took);
    }
  } else {
    rcl_reset_error();
    probe_stage("service", "fail", "the executor could not take the service and the client");
  }
  (void)rclc_executor_fini(&executor);
  probe_ignore(rcl_client_fini(&client, &session->node));
  probe_ignore(rcl_service_fini(&service, &session->node));
  rcl_reset_error();
  return status;
}
#else
int stage_service(probe_session_t *session) {
  (void)session;
  probe_stage("service", "skip",
              "the library has no example_interfaces/srv/AddTwoInts (uros build --packages example_interfaces)");
  return 0;
}
#endif
