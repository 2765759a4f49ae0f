/* A micro-ROS node with an rclc parameter server, as a user would write it (micro-ROS-demos'
 * rclc/parameter_server and micro_ros_arduino#1596's options), as an appMain app that `uros probe --app`
 * runs in QEMU against the agent:
 *
 * - node "param_node" with a parameter server (rclc_parameter_server_init_with_option: notify changes
 *   over DDS, APP_MAX_PARAMS slots, low-memory mode APP_LOW_MEM, off) and APP_PARAMS int parameters
 *   param_0 ... (values 0, 10, 20, ...), added one by one, each call's result printed;
 * - an executor initialised for exactly what the server needs (APP_HANDLES:
 *   RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES; fewer makes rclc_executor_add_parameter_server fail);
 * - with APP_SELF_CHECK (default) it asks its own server through the agent, as `ros2 param get` would:
 *   a GetParameters request for each parameter, from a client of its own, and checks the values.
 *
 * The library needs room for it: 5 services and 1 publisher (`uros check LIB --for-firmware DIR` counts
 * them from this file), rclc_parameter in the library, and with APP_SELF_CHECK one client.
 *
 * exit(0) when every parameter was added and (APP_SELF_CHECK) read back right through the agent; 1 the
 * parameter server could not be created, 2 a parameter could not be added (the line says which and
 * rclc's return code), 3 the executor, 4 the self-check's client, 5 no answer or wrong values, 6 (with
 * -D APP_PEER_WAIT_MS=N) the ROS 2 peer (peer.py) did not set param_0 to 123 within N ms. */
#include <micro_ros_utilities/type_utilities.h>
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rcl_interfaces/msg/parameter_type.h>
#include <rcl_interfaces/srv/get_parameters.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <rclc_parameter/rclc_parameter.h>
#include <rcutils/time.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef APP_PARAMS
#define APP_PARAMS 6
#endif
#ifndef APP_MAX_PARAMS
#define APP_MAX_PARAMS APP_PARAMS
#endif
/* rclc's low-memory mode (micro_ros_arduino#1596's choice) takes one name a get request and, in humble,
 * leaves a set request's string_value unallocated, so a ROS 2 client's set is never answered: off */
#ifndef APP_LOW_MEM
#define APP_LOW_MEM 0
#endif
#ifndef APP_SELF_CHECK
#define APP_SELF_CHECK 1
#endif
/* the executor's handles: what the parameter server needs (fewer: rclc_executor_add_parameter_server fails) */
#ifndef APP_HANDLES
#define APP_HANDLES RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES
#endif
#define APP_CHECK_MS 8000u
/* with a ROS 2 peer (peer.py): wait this long for it to set param_0 to APP_PEER_VALUE (0: no peer) */
#ifndef APP_PEER_WAIT_MS
#define APP_PEER_WAIT_MS 0u
#endif
#define APP_PEER_VALUE 123

static uint32_t now_ms(void) {
  rcutils_time_point_value_t now = 0;
  (void)rcutils_steady_time_now(&now);
  return (uint32_t)(now / 1000000);
}

static bool peer_set;
static bool on_changed(const Parameter *old, const Parameter *new, void *context) {
  (void)old;
  (void)context;
  if (new != NULL && strcmp(new->name.data, "param_0") == 0 && new->value.integer_value == APP_PEER_VALUE) {
    peer_set = true;
  }
  return true;
}

static bool answered;
static void on_response(const void *response) {
  (void)response;
  answered = true;
}

static rcl_node_t node;
static rclc_support_t support;
static rclc_parameter_server_t param_server;
static rclc_executor_t executor;

#if APP_SELF_CHECK
/* GetParameters for each parameter in turn, one name a request as `ros2 param get` asks (a server in
 * low-memory mode takes one name a request: rclc_parameter's init_parameter_server_memory_low gives its
 * get request a capacity of 1), from a client of its own, through the agent (a request every 250 ms
 * until the answer); 0 when every value came back right. */
static int self_check(rcl_allocator_t *allocator) {
  rcl_client_t client = rcl_get_zero_initialized_client();
  if (rclc_client_init_default(&client, &node, ROSIDL_GET_SRV_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters),
                               "param_node/get_parameters") != RCL_RET_OK) {
    printf("app: the self-check's client could not be created (RMW_UXRCE_MAX_CLIENTS)\n");
    return 4;
  }
  rcl_interfaces__srv__GetParameters_Response response;
  memset(&response, 0, sizeof(response));
  micro_ros_utilities_memory_conf_t conf = {20, 1, 5, NULL, 0, NULL};
  micro_ros_utilities_create_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters_Response),
                                            &response, conf);
  rclc_executor_t checker = rclc_executor_get_zero_initialized_executor();
  int status = 3, right = 0;
  if (rclc_executor_init(&checker, &support.context, 1, allocator) == RCL_RET_OK &&
      rclc_executor_add_client(&checker, &client, &response, on_response) == RCL_RET_OK) {
    status = 5;
    for (int i = 0; i < APP_PARAMS; i++) {
      char name[16];
      snprintf(name, sizeof name, "param_%d", i);
      rosidl_runtime_c__String one = {.data = name, .size = strlen(name), .capacity = sizeof name};
      rcl_interfaces__srv__GetParameters_Request request = {.names = {.data = &one, .size = 1, .capacity = 1}};
      answered = false;
      uint32_t begin = now_ms();
      while (!answered && now_ms() - begin < APP_CHECK_MS) {
        int64_t sequence;
        (void)rcl_send_request(&client, &request, &sequence);
        uint32_t asked = now_ms();
        while (!answered && now_ms() - asked < 250u) {
          rclc_executor_spin_some(&executor, RCL_MS_TO_NS(5)); /* the server answers */
          rclc_executor_spin_some(&checker, RCL_MS_TO_NS(5));  /* the client hears it */
        }
      }
      bool ok = answered && response.values.size == 1 &&
                response.values.data[0].type == rcl_interfaces__msg__ParameterType__PARAMETER_INTEGER &&
                response.values.data[0].integer_value == (int64_t)(10 * i);
      printf("app: get_parameters %s through the agent: %s\n", name, !answered ? "no answer" : ok ? "right" : "wrong");
      right += ok;
      if (!answered) break;
    }
    if (right == APP_PARAMS) status = 0;
  }
  (void)rclc_executor_fini(&checker);
  (void)rcl_client_fini(&client, &node);
  micro_ros_utilities_destroy_message_memory(ROSIDL_GET_MSG_TYPE_SUPPORT(rcl_interfaces, srv, GetParameters_Response),
                                             &response, conf);
  return status;
}
#endif

void appMain(void *argument) {
  (void)argument;
  rcl_allocator_t allocator = rcl_get_default_allocator();
  if (rclc_support_init(&support, 0, NULL, &allocator) != RCL_RET_OK ||
      rclc_node_init_default(&node, "param_node", "", &support) != RCL_RET_OK) {
    printf("app: no session or node\n");
    exit(1);
  }
  const rclc_parameter_options_t options = {
      .notify_changed_over_dds = true,
      .max_params = APP_MAX_PARAMS,
      .allow_undeclared_parameters = false,
      .low_mem_mode = APP_LOW_MEM,
  };
  rcl_ret_t rc = rclc_parameter_server_init_with_option(&param_server, &node, &options);
  printf("app: rclc_parameter_server_init_with_option (max_params %d, low_mem_mode %d): %d\n", APP_MAX_PARAMS,
         APP_LOW_MEM, (int)rc);
  if (rc != RCL_RET_OK) exit(1);
  if (rclc_executor_init(&executor, &support.context, APP_HANDLES, &allocator) != RCL_RET_OK) exit(3);
  rc = rclc_executor_add_parameter_server(&executor, &param_server, on_changed);
  if (rc != RCL_RET_OK) {
    printf("app: rclc_executor_add_parameter_server returned %d: the executor (%d handles) could not take the "
           "parameter server (%d)\n",
           (int)rc, APP_HANDLES, RCLC_EXECUTOR_PARAMETER_SERVER_HANDLES);
    exit(3);
  }
  for (int i = 0; i < APP_PARAMS; i++) {
    char name[16];
    snprintf(name, sizeof name, "param_%d", i);
    rc = rclc_add_parameter(&param_server, name, RCLC_PARAMETER_INT);
    rcl_ret_t set = rc == RCL_RET_OK ? rclc_parameter_set_int(&param_server, name, 10 * i) : rc;
    printf("app: parameter %d (%s): rclc_add_parameter %d, rclc_parameter_set_int %d%s%s\n", i + 1, name, (int)rc,
           (int)set, rcl_error_is_set() ? ": " : "", rcl_error_is_set() ? rcl_get_error_string().str : "");
    rcl_reset_error();
    if (rc != RCL_RET_OK || set != RCL_RET_OK) exit(2);
  }
  int status = 0;
#if APP_SELF_CHECK
  status = self_check(&allocator);
#endif
  if (status == 0 && APP_PEER_WAIT_MS > 0) { /* the peer lists, gets, describes, then sets param_0 */
    uint32_t begin = now_ms();
    while (!peer_set && now_ms() - begin < APP_PEER_WAIT_MS) rclc_executor_spin_some(&executor, RCL_MS_TO_NS(10));
    uint32_t set_at = now_ms();
    while (peer_set && now_ms() - set_at < 1000u) rclc_executor_spin_some(&executor, RCL_MS_TO_NS(10));
    int64_t value = 0;
    (void)rclc_parameter_get_int(&param_server, "param_0", &value);
    printf("app: the peer %s param_0 (now %ld)\n", peer_set ? "set" : "did not set", (long)value);
    if (!peer_set) status = 6;
  }
  printf("app: tearing down\n");
  (void)rclc_executor_fini(&executor);
  (void)rclc_parameter_server_fini(&param_server, &node);
  (void)rcl_node_fini(&node);
  (void)rclc_support_fini(&support);
  printf("app: %s\n", status == 0 ? "every parameter added and read back" : "FAIL");
  exit(status);
}
