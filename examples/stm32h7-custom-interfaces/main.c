/* An rclc node on an STM32H743 (seed 001): publishes and subscribes eic_demo_interface/CmdVel and
 * calls the GetTime service, over a custom transport (USB CDC on the board). */
#include <stdio.h>

#include <eic_demo_interface/msg/cmd_vel.h>
#include <eic_demo_interface/srv/get_time.h>
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <rmw_microros/rmw_microros.h>

#include "board.h"

static rcl_publisher_t publisher;
static rcl_subscription_t subscriber;
static rcl_client_t client;
static eic_demo_interface__msg__CmdVel velocity_out;
static eic_demo_interface__msg__CmdVel velocity_in;
static eic_demo_interface__srv__GetTime_Request time_request;
static eic_demo_interface__srv__GetTime_Response time_response;
static volatile int64_t last_host_time_ms;

static void subscription_callback(const void *msgin) {
  const eic_demo_interface__msg__CmdVel *msg = (const eic_demo_interface__msg__CmdVel *)msgin;
  velocity_out.left_rpm = msg->left_rpm;
  velocity_out.right_rpm = msg->right_rpm;
}

static void client_callback(const void *response_msg) {
  const eic_demo_interface__srv__GetTime_Response *res = (const eic_demo_interface__srv__GetTime_Response *)response_msg;
  last_host_time_ms = res->time_ms_res;
}

int main(void) {
  rmw_uros_set_custom_transport(true, NULL, board_transport_open, board_transport_close, board_transport_write,
                                board_transport_read);

  rcl_allocator_t allocator = rcl_get_default_allocator();
  rclc_support_t support;
  if (rclc_support_init(&support, 0, NULL, &allocator) != RCL_RET_OK) {
    return 1;
  }
  rcl_node_t node;
  rclc_node_init_default(&node, "stm32h7_node", "", &support);
  rclc_publisher_init_default(&publisher, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(eic_demo_interface, msg, CmdVel),
                              "pub_topic");
  rclc_subscription_init_default(&subscriber, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(eic_demo_interface, msg, CmdVel),
                                 "sub_topic");
  rclc_client_init_default(&client, &node, ROSIDL_GET_SRV_TYPE_SUPPORT(eic_demo_interface, srv, GetTime), "get_time");

  rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
  rclc_executor_init(&executor, &support.context, 2, &allocator);
  rclc_executor_add_subscription(&executor, &subscriber, &velocity_in, subscription_callback, ON_NEW_DATA);
  rclc_executor_add_client(&executor, &client, &time_response, client_callback);
  eic_demo_interface__srv__GetTime_Request__init(&time_request);

  int64_t sequence = 0;
  for (;;) {
    rclc_executor_spin_some(&executor, RCL_MS_TO_NS(100));
    if (rcl_publish(&publisher, &velocity_out, NULL) != RCL_RET_OK) {
      continue; /* agent not reachable yet: a real board would back off or reconnect here */
    }
    time_request.time_ms_req = sequence;
    if (rcl_send_request(&client, &time_request, &sequence) == RCL_RET_OK) {
      velocity_out.left_rpm++;
    }
  }
}
