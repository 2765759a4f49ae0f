/* Seed 001's micro-ROS application (STM32H743, FreeRTOS task, custom interfaces), as an appMain app:
 * the same rclc code a user flashes, run by `uros probe --app` on a Cortex-M7 in QEMU.
 *
 * - micro-ROS's allocator is routed to the board's heap through microros_allocate & co (on the
 *   STM32 project: micro_ros_stm32cubemx_utils' microros_allocators.c over pvPortMalloc; in the
 *   probe: the board's heap) and made rcl's default with rcutils_set_default_allocator;
 * - node "test_node" publishes eic_demo_interface/msg/CmdVel on "pub_topic" (left_rpm counts up,
 *   right_rpm = -2 * left_rpm) and serves eic_demo_interface/srv/GetTime on "get_time" (answers its
 *   clock in ms: the agent's epoch after rmw_uros_sync_session, else its uptime; never 0);
 * - it checks its own work through the agent, as the seed's subscriber and client do: its
 *   subscription listens on "pub_topic" (-D APP_SUB_TOPIC=\"sub_topic\" for the seed's topic) and
 *   its client calls "get_time".
 *
 * exit(0) once APP_SAMPLES CmdVel came back intact, its own GetTime call was answered, and
 * APP_PEER_REQUESTS more requests (a ROS 2 peer's) were served; 1 an entity could not be created,
 * 2 samples lost or wrong, 3 GetTime not answered (or answered wrongly), 4 the peer's requests
 * did not come, all within APP_CHECK_MS (APP_PEER_WAIT_MS for the peer). */
#include <eic_demo_interface/msg/cmd_vel.h>
#include <eic_demo_interface/srv/get_time.h>
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <rcutils/time.h>
#include <rmw_microros/rmw_microros.h>
#include <stdio.h>
#include <stdlib.h>

#ifndef APP_SUB_TOPIC
#define APP_SUB_TOPIC "pub_topic"
#endif
#ifndef APP_SAMPLES
#define APP_SAMPLES 10
#endif
#ifndef APP_PEER_REQUESTS
#define APP_PEER_REQUESTS 0
#endif
#ifndef APP_CHECK_MS
#define APP_CHECK_MS 10000
#endif
#ifndef APP_PEER_WAIT_MS
#define APP_PEER_WAIT_MS 30000
#endif

/* The board's heap (micro_ros_stm32cubemx_utils names). */
void *microros_allocate(size_t size, void *state);
void microros_deallocate(void *pointer, void *state);
void *microros_reallocate(void *pointer, size_t size, void *state);
void *microros_zero_allocate(size_t number_of_elements, size_t size_of_element, void *state);

#define RCCHECK(fn)                                                                  \
  {                                                                                  \
    rcl_ret_t temp_rc = fn;                                                          \
    if ((temp_rc != RCL_RET_OK)) {                                                   \
      printf("app: %s failed on line %d: %d. Aborting.\n", #fn, __LINE__, (int)temp_rc); \
      exit(1);                                                                       \
    }                                                                                \
  }
#define RCSOFTCHECK(fn)                                                              \
  {                                                                                  \
    rcl_ret_t temp_rc = fn;                                                          \
    if ((temp_rc != RCL_RET_OK)) {                                                   \
      printf("app: %s failed on line %d: %d. Continuing.\n", #fn, __LINE__, (int)temp_rc); \
    }                                                                                \
  }

rcl_publisher_t publisher;
rcl_subscription_t subscriber;
rcl_service_t service;
rcl_client_t client;
eic_demo_interface__msg__CmdVel velocity_data;
eic_demo_interface__msg__CmdVel sub_msg;
eic_demo_interface__srv__GetTime_Request req_msg;
eic_demo_interface__srv__GetTime_Response res_msg;
eic_demo_interface__srv__GetTime_Request served_req;
eic_demo_interface__srv__GetTime_Response served_res;
int64_t num_of_req = 1;

static int time_synced;
static int samples_back, samples_wrong;
static int32_t last_back;
static int own_answer; /* 0 none yet, 1 right, -1 wrong */
static int served, own_sent;

static int64_t now_ms(void) {
  if (time_synced) return rmw_uros_epoch_millis();
  rcutils_time_point_value_t ns = 0;
  if (rcutils_steady_time_now(&ns) != RCUTILS_RET_OK) return 1;
  return RCUTILS_NS_TO_MS(ns) + 1; /* never 0: 0 is "invalid" to the seed */
}

void subscription_callback(const void *msgin) {
  const eic_demo_interface__msg__CmdVel *msg = (const eic_demo_interface__msg__CmdVel *)msgin;
  if (msg->right_rpm == -2 * msg->left_rpm && msg->left_rpm > last_back && msg->left_rpm <= velocity_data.left_rpm) {
    samples_back++;
    last_back = msg->left_rpm;
  } else {
    samples_wrong++;
    printf("app: CmdVel came back wrong: left_rpm %ld, right_rpm %ld\n", (long)msg->left_rpm, (long)msg->right_rpm);
  }
}

void service_callback(const void *request, void *response) {
  const eic_demo_interface__srv__GetTime_Request *req = (const eic_demo_interface__srv__GetTime_Request *)request;
  eic_demo_interface__srv__GetTime_Response *res = (eic_demo_interface__srv__GetTime_Response *)response;
  res->time_ms_res = now_ms();
  served++;
  /* newlib-nano's printf has no %lld: milliseconds as seconds and a remainder */
  printf("app: get_time request %ld.%03ld answered %ld.%03ld\n", (long)(req->time_ms_req / 1000),
         (long)(req->time_ms_req % 1000), (long)(res->time_ms_res / 1000), (long)(res->time_ms_res % 1000));
}

void client_callback(const void *response_msg) {
  const eic_demo_interface__srv__GetTime_Response *msgin = (const eic_demo_interface__srv__GetTime_Response *)response_msg;
  printf("app: RESPONSE: TIME = %ld.%03ld s\n", (long)(msgin->time_ms_res / 1000), (long)(msgin->time_ms_res % 1000));
  /* the seed's check, and the answer is no older than the question */
  own_answer = (msgin->time_ms_res != 0 && msgin->time_ms_res >= req_msg.time_ms_req) ? 1 : -1;
}

void appMain(void *argument) {
  (void)argument;
  rcl_allocator_t freeRTOS_allocator = rcutils_get_zero_initialized_allocator();
  freeRTOS_allocator.allocate = microros_allocate;
  freeRTOS_allocator.deallocate = microros_deallocate;
  freeRTOS_allocator.reallocate = microros_reallocate;
  freeRTOS_allocator.zero_allocate = microros_zero_allocate;
  if (!rcutils_set_default_allocator(&freeRTOS_allocator)) {
    printf("app: rcutils_set_default_allocator failed\n");
    exit(1);
  }

  rclc_support_t support;
  RCCHECK(rclc_support_init(&support, 0, NULL, &freeRTOS_allocator));
  time_synced = rmw_uros_sync_session(1000) == RMW_RET_OK;
  printf("app: clock %s\n", time_synced ? "synchronised with the agent" : "not synchronised: uptime");

  rcl_node_t node;
  RCCHECK(rclc_node_init_default(&node, "test_node", "", &support));
  RCCHECK(rclc_publisher_init_default(&publisher, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(eic_demo_interface, msg, CmdVel),
                                      "pub_topic"));
  RCCHECK(rclc_subscription_init_default(&subscriber, &node,
                                         ROSIDL_GET_MSG_TYPE_SUPPORT(eic_demo_interface, msg, CmdVel), APP_SUB_TOPIC));
  RCCHECK(rclc_service_init_default(&service, &node, ROSIDL_GET_SRV_TYPE_SUPPORT(eic_demo_interface, srv, GetTime),
                                    "get_time"));
  RCCHECK(rclc_client_init_default(&client, &node, ROSIDL_GET_SRV_TYPE_SUPPORT(eic_demo_interface, srv, GetTime),
                                   "get_time"));

  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  RCCHECK(rclc_executor_init(&executor, &support.context, 3, &freeRTOS_allocator));
  RCCHECK(rclc_executor_add_subscription(&executor, &subscriber, &sub_msg, &subscription_callback, ON_NEW_DATA));
  RCCHECK(rclc_executor_add_service(&executor, &service, &served_req, &served_res, service_callback));
  RCCHECK(rclc_executor_add_client(&executor, &client, &res_msg, client_callback));
  eic_demo_interface__srv__GetTime_Request__init(&req_msg);
  printf("app: publishing CmdVel on pub_topic, serving get_time\n");

  int64_t start = now_ms(), last_request = 0;
  for (;;) {
    RCSOFTCHECK(rclc_executor_spin_some(&executor, RCL_MS_TO_NS(20)));
    velocity_data.left_rpm++;
    velocity_data.right_rpm = -2 * velocity_data.left_rpm;
    RCSOFTCHECK(rcl_publish(&publisher, &velocity_data, NULL));
    int64_t now = now_ms();
    if (own_answer == 0 && now - last_request >= 500) { /* again until the replier is matched */
      req_msg.time_ms_req = now;
      RCSOFTCHECK(rcl_send_request(&client, &req_msg, &num_of_req));
      last_request = now;
      own_sent++;
    }
    int own_done = samples_back >= APP_SAMPLES && own_answer == 1;
    if (own_done && served - own_sent >= APP_PEER_REQUESTS) {
      printf("app: PASS %d CmdVel back, get_time answered, %d requests served\n", samples_back, served);
      exit(0);
    }
    if (samples_wrong > 0 || (now - start > APP_CHECK_MS && samples_back < APP_SAMPLES)) {
      printf("app: FAIL %d of %d CmdVel came back (%d wrong)\n", samples_back, APP_SAMPLES, samples_wrong);
      exit(2);
    }
    if (own_answer < 0 || (now - start > APP_CHECK_MS && own_answer == 0)) {
      printf("app: FAIL get_time %s\n", own_answer < 0 ? "answered wrongly" : "not answered");
      exit(3);
    }
    if (now - start > APP_PEER_WAIT_MS) {
      printf("app: FAIL %d of the peer's %d get_time requests came\n", served - own_sent, APP_PEER_REQUESTS);
      exit(4);
    }
  }
}
