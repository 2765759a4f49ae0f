/* uros probe, stage limits: what the library's colcon.meta really permits, at run time. As many
 * entities of each kind as RMW_UXRCE_MAX_* allow (compiled into rmw_microxrcedds_c/config.h, so the
 * numbers are the library's), then one more, which must be refused with an error, not a crash.
 * Capped at PROBE_MAX_EXTRA per kind (the pools are static). */
#include <rcl/error_handling.h>
#include <rmw_microxrcedds_c/config.h>
#include <stdio.h>

#include "fleet.h"
#include "stages.h"

#define PROBE_MAX_EXTRA 16
enum probe_kind { KIND_NODE, KIND_PUBLISHER, KIND_SUBSCRIPTION };
static const char *const kind_names[] = {"nodes", "publishers", "subscriptions"};
static const char *const kind_options[] = {"NODES", "PUBLISHERS", "SUBSCRIPTIONS"};
static const int kind_limits[] = {RMW_UXRCE_MAX_NODES, RMW_UXRCE_MAX_PUBLISHERS, RMW_UXRCE_MAX_SUBSCRIPTIONS};
static rcl_node_t extra_nodes[PROBE_MAX_EXTRA];
static rcl_publisher_t extra_publishers[PROBE_MAX_EXTRA];
static rcl_subscription_t extra_subscriptions[PROBE_MAX_EXTRA];

static rcl_ret_t make_entity(enum probe_kind kind, int i, probe_session_t *session,
                             const rosidl_message_type_support_t *type) {
  char name[32];
  snprintf(name, sizeof name, "uros_probe_%s_%d", kind == KIND_NODE ? "n" : "t", i);
  switch (kind) {
    case KIND_NODE:
      extra_nodes[i] = rcl_get_zero_initialized_node();
      return rclc_node_init_default(&extra_nodes[i], name, probe_namespace(), &session->support);
    case KIND_PUBLISHER:
      extra_publishers[i] = rcl_get_zero_initialized_publisher();
      return rclc_publisher_init_default(&extra_publishers[i], &session->node, type, name);
    default:
      extra_subscriptions[i] = rcl_get_zero_initialized_subscription();
      return rclc_subscription_init_default(&extra_subscriptions[i], &session->node, type, name);
  }
}

static void drop_entity(enum probe_kind kind, int i, rcl_node_t *node) {
  if (kind == KIND_NODE) probe_ignore(rcl_node_fini(&extra_nodes[i]));
  if (kind == KIND_PUBLISHER) probe_ignore(rcl_publisher_fini(&extra_publishers[i], node));
  if (kind == KIND_SUBSCRIPTION) probe_ignore(rcl_subscription_fini(&extra_subscriptions[i], node));
}

/* One of each kind exists already. 0, or 4 when the library allows other than it says. */
static int probe_limit(enum probe_kind kind, probe_session_t *session, const rosidl_message_type_support_t *type) {
  int limit = kind_limits[kind];
  int more = limit - 1, checked = 1;
  if (more >= PROBE_MAX_EXTRA) {
    more = PROBE_MAX_EXTRA - 1;
    checked = 0; /* the pool is larger than the probe goes: no "one more" */
  }
  int made = 0, status = 0;
  for (; made < more; made++) {
    if (make_entity(kind, made, session, type) != RCL_RET_OK) {
      printf("uros-probe: FAIL %s: number %d of the %d RMW_UXRCE_MAX_%s allows could not be created\n",
             kind_names[kind], made + 2, limit, kind_options[kind]);
      probe_stage("limits", "fail", "%s: number %d of the %d RMW_UXRCE_MAX_%s allows could not be created",
                  kind_names[kind], made + 2, limit, kind_options[kind]);
      rcl_reset_error();
      status = PROBE_NO_ENTITY;
      break;
    }
  }
  if (status == 0 && checked) {
    if (make_entity(kind, made, session, type) == RCL_RET_OK) {
      printf("uros-probe: FAIL %s: one more than the %d allowed was created\n", kind_names[kind], limit);
      probe_stage("limits", "fail", "%s: one more than RMW_UXRCE_MAX_%s=%d was created", kind_names[kind],
                  kind_options[kind], limit);
      drop_entity(kind, made, &session->node);
      status = PROBE_NO_ENTITY;
    }
    rcl_reset_error();
  }
  if (status == 0) printf("uros-probe: limit %s %d %s\n", kind_names[kind], limit, checked ? "refused" : "unchecked");
  while (made-- > 0) drop_entity(kind, made, &session->node);
  return status;
}

int stage_limits(probe_session_t *session, probe_loop_t *loop) {
  (void)loop; /* its publisher and subscription are the first of their kinds */
  const rosidl_message_type_support_t *int32 = ROSIDL_GET_MSG_TYPE_SUPPORT(std_msgs, msg, Int32);
  for (int kind = KIND_NODE; kind <= KIND_SUBSCRIPTION; kind++) {
    int status = probe_limit((enum probe_kind)kind, session, int32);
    if (status != 0) return status;
  }
  probe_stage("limits", "pass", "nodes %d, publishers %d, subscriptions %d",
              RMW_UXRCE_MAX_NODES, RMW_UXRCE_MAX_PUBLISHERS, RMW_UXRCE_MAX_SUBSCRIPTIONS);
  return 0;
}
