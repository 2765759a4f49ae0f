/* uros probe, stage parameters: an rclc parameter server (rclc_parameter) with three typed parameters
 * (bool, int, double) on the probe's node, checked by the firmware itself through the agent, without a
 * peer: its own clients of rcl_interfaces' GetParameters, SetParameters and ListParameters call the
 * server's services ("uros_probe/get_parameters", ...) as `ros2 param` would. A parameter server takes
 * a service for each of its RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES executor handles (5 in humble: get,
 * get_types, set, list, describe; 6 from iron on) and a publisher (rclc_parameter's parameter_server.c); a library without that room, or without
 * rclc_parameter, skips the stage and says why, never `pass`. Each call is a client and an executor of
 * its own, made and finished in turn, so one RMW_UXRCE_MAX_CLIENTS slot is enough. */
#include <rcl/error_handling.h>
#include <rmw_microxrcedds_c/config.h>
#include <stdio.h>
#include <string.h>

#include "probe.h"
#include "stages.h"

#define PROBE_PARAMETER_MS 5000u

#if __has_include(<rclc_parameter/rclc_parameter.h>) && __has_include(<rcl_interfaces/srv/get_parameters.h>) && \
    __has_include(<micro_ros_utilities/type_utilities.h>)
#include <micro_ros_utilities/type_utilities.h>
#include <rcl_interfaces/msg/parameter_type.h>
#include <rcl_interfaces/srv/get_parameters.h>
#include <rcl_interfaces/srv/list_parameters.h>
#include <rcl_interfaces/srv/set_parameters.h>
#include <rclc_parameter/rclc_parameter.h>

static bool answered;
static int changes;
static int64_t changed_to;

static void on_response(const void *response) {
  (void)response;
  answered = true;
}

static bool on_changed(const Parameter *old, const Parameter *new, void *context) {
  (void)context;
  if (old != NULL && new != NULL && strcmp(new->name.data, "uros_count") == 0) {
    changes++;
    changed_to = new->value.integer_value;
  }
  return true;
}

static rosidl_runtime_c__String text(char *value) {
  rosidl_runtime_c__String out = {.data = value, .size = strlen(value), .capacity = strlen(value) + 1};
  return out;
}

/* One request to one of the server's services, sent every 250 ms until answered (the agent's DDS
 * endpoints match a moment after creation), for at most PROBE_PARAMETER_MS: a client and an executor
 * (the server's handles and the client's) of its own. 0 when answered, else what failed. */
static const char *call(probe_session_t *session, rclc_parameter_server_t *server,
                        const rosidl_service_type_support_t *type, const char *name, const void *request,
                        void *response, uint32_t *took) {
  rcl_client_t client = rcl_get_zero_initialized_client();
  if (rclc_client_init_default(&client, &session->node, type, name) != RCL_RET_OK) {
    rcl_reset_error();
    return "client";
  }
  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  const char *failed = "executor";
  if (rclc_executor_init(&executor, &session->support.context, RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES + 1,
                         &session->allocator) == RCL_RET_OK &&
      rclc_executor_add_parameter_server(&executor, server, on_changed) == RCL_RET_OK &&
      rclc_executor_add_client(&executor, &client, response, on_response) == RCL_RET_OK) {
    failed = "no answer";
    uint32_t begin = probe_millis();
    answered = false;
    while (!answered && probe_millis() - begin < PROBE_PARAMETER_MS) {
      int64_t sequence;
      if (rcl_send_request(&client, request, &sequence) != RCL_RET_OK) rcl_reset_error();
      uint32_t asked = probe_millis();
      while (!answered && probe_millis() - asked < 250u) rclc_executor_spin_some(&executor, RCL_MS_TO_NS(5));
    }
    *took += probe_millis() - begin;
    if (answered) failed = NULL;
  }
  rcl_reset_error();
  (void)rclc_executor_fini(&executor);
  probe_ignore(rcl_client_fini(&client, &session->node));
  return failed;
}

static const micro_ros_utilities_memory_conf_t memory = {20, 5, 5, NULL, 0, NULL};

/* The three calls: 1 when every answer was right, else 0 and what was wrong in `why`. */
static int check(probe_session_t *session, rclc_parameter_server_t *server, char *why, size_t size,
                 uint32_t *took) {
  /* get: the three values as the firmware set them */
  rosidl_runtime_c__String names[3] = {text("uros_count"), text("uros_gain"), text("uros_flag")};
  rcl_interfaces__srv__GetParameters_Request get = {.names = {.data = names, .size = 3, .capacity = 3}};
  rcl_interfaces__srv__GetParameters_Response got;
  memset(&got, 0, sizeof(got));
  micro_ros_utilities_create_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters_Response),
                                            &got, memory);
  const char *failed = call(session, server, ROSIDL_GET_SRV_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters),
                            "uros_probe/get_parameters", &get, &got, took);
  int ok = failed == NULL && got.values.size == 3 &&
           got.values.data[0].type == rcl_interfaces__msg__ParameterType__PARAMETER_INTEGER &&
           got.values.data[0].integer_value == 42 &&
           got.values.data[1].type == rcl_interfaces__msg__ParameterType__PARAMETER_DOUBLE &&
           got.values.data[1].double_value == 0.5 &&
           got.values.data[2].type == rcl_interfaces__msg__ParameterType__PARAMETER_BOOL &&
           got.values.data[2].bool_value;
  if (!ok) {
    snprintf(why, size, "get_parameters: %s", failed != NULL ? failed : "the values that came back are not 42, 0.5, true");
  }
  micro_ros_utilities_destroy_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters_Response),
                                             &got, memory);
  if (!ok) return 0;

  /* set: uros_count = 7, seen by the server's callback and by rclc_parameter_get_int */
  static char empty[1];
  rcl_interfaces__msg__Parameter parameter;
  memset(&parameter, 0, sizeof(parameter));
  parameter.name = text("uros_count");
  parameter.value.type = rcl_interfaces__msg__ParameterType__PARAMETER_INTEGER;
  parameter.value.integer_value = 7;
  parameter.value.string_value = (rosidl_runtime_c__String){.data = empty, .size = 0, .capacity = 1};
  rcl_interfaces__srv__SetParameters_Request set = {.parameters = {.data = &parameter, .size = 1, .capacity = 1}};
  rcl_interfaces__srv__SetParameters_Response result;
  memset(&result, 0, sizeof(result));
  micro_ros_utilities_create_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, SetParameters_Response),
                                            &result, memory);
  failed = call(session, server, ROSIDL_GET_SRV_TYPE_SUPPORT(rcl_interfaces, srv, SetParameters),
                "uros_probe/set_parameters", &set, &result, took);
  int64_t now = 0;
  probe_ignore(rclc_parameter_get_int(server, "uros_count", &now));
  ok = failed == NULL && result.results.size == 1 && result.results.data[0].successful && now == 7 &&
       changes == 1 && changed_to == 7;
  if (!ok) {
    snprintf(why, size, "set_parameters: %s (the server holds %ld, its callback saw %d changes)",
             failed != NULL ? failed : "not taken", (long)now, changes);
  }
  micro_ros_utilities_destroy_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, SetParameters_Response),
                                             &result, memory);
  if (!ok) return 0;

  /* list: the three names */
  rcl_interfaces__srv__ListParameters_Request list;
  memset(&list, 0, sizeof(list));
  rcl_interfaces__srv__ListParameters_Response listed;
  memset(&listed, 0, sizeof(listed));
  micro_ros_utilities_create_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, ListParameters_Response),
                                            &listed, memory);
  failed = call(session, server, ROSIDL_GET_SRV_TYPE_SUPPORT(rcl_interfaces, srv, ListParameters),
                "uros_probe/list_parameters", &list, &listed, took);
  ok = failed == NULL && listed.result.names.size == 3;
  if (!ok) {
    snprintf(why, size, "list_parameters: %s", failed != NULL ? failed : "not the 3 names");
  }
  micro_ros_utilities_destroy_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, ListParameters_Response),
                                             &listed, memory);
  return ok;
}

int stage_parameters(probe_session_t *session) {
#if RMW_UXRCE_MAX_SERVICES < RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES
  (void)session;
  probe_stage("parameters", "skip",
              "a parameter server takes %d services and the library has RMW_UXRCE_MAX_SERVICES=%d "
              "(uros build --set rmw_microxrcedds.RMW_UXRCE_MAX_SERVICES=%d)",
              RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES, RMW_UXRCE_MAX_SERVICES, RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES);
  return 0;
#else
  rclc_parameter_server_t server;
  rcl_ret_t ret = rclc_parameter_server_init_default(&server, &session->node);
  if (ret != RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("parameters", "fail",
                "the parameter server could not be created (rclc_parameter_server_init_default returned %d; it "
                "takes %d services and a publisher: RMW_UXRCE_MAX_SERVICES=%d, RMW_UXRCE_MAX_PUBLISHERS=%d)",
                (int)ret, RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES, RMW_UXRCE_MAX_SERVICES, RMW_UXRCE_MAX_PUBLISHERS);
    return PROBE_PARAMETERS;
  }
  int status = PROBE_PARAMETERS;
  changes = 0;
  if (rclc_add_parameter(&server, "uros_flag", RCLC_PARAMETER_BOOL) != RCL_RET_OK ||
      rclc_add_parameter(&server, "uros_count", RCLC_PARAMETER_INT) != RCL_RET_OK ||
      rclc_add_parameter(&server, "uros_gain", RCLC_PARAMETER_DOUBLE) != RCL_RET_OK ||
      rclc_parameter_set_bool(&server, "uros_flag", true) != RCL_RET_OK ||
      rclc_parameter_set_int(&server, "uros_count", 42) != RCL_RET_OK ||
      rclc_parameter_set_double(&server, "uros_gain", 0.5) != RCL_RET_OK) {
    rcl_reset_error();
    probe_stage("parameters", "fail", "rclc_add_parameter or rclc_parameter_set_* refused a parameter");
  } else {
    char why[160] = "";
    uint32_t took = 0;
    if (check(session, &server, why, sizeof(why), &took)) {
      probe_stage("parameters", "pass",
                  "3 parameters (bool, int, double) got, set (the server's callback saw uros_count=7) and listed "
                  "through the agent in %lu ms",
                  (unsigned long)took);
      status = 0;
    } else {
      probe_stage("parameters", "fail", "%s", why);
    }
  }
  probe_ignore(rclc_parameter_server_fini(&server, &session->node));
  rcl_reset_error();
  return status;
#endif
}
#else
int stage_parameters(probe_session_t *session) {
  (void)session;
  probe_stage("parameters", "skip",
              "the library has no rclc_parameter and rcl_interfaces (uros build --packages rclc_parameter)");
  return 0;
}
#endif
