/* An ESP32-S3 micro-ROS node (seed 000, done with uros): joins Wi-Fi, reaches a micro-ROS agent over
 * UDP, publishes the LED's colour as demo_interfaces/msg/Hsb on state/led/hsb every
 * CONFIG_UROS_STATE_PERIOD_MS and takes new colours from command/led/hsb.
 *
 * The agent: `docker run -it --rm --net=host microros/micro-ros-agent:humble udp4 --port 8888`.
 * Settings (Wi-Fi, agent address, node name, period): `idf.py menuconfig`, "micro-ROS HSB node". */

#include <string.h>

#include "esp_event.h"
#include "esp_log.h"
#include "esp_netif.h"
#include "esp_wifi.h"
#include "freertos/FreeRTOS.h"
#include "freertos/event_groups.h"
#include "freertos/task.h"
#include "nvs_flash.h"

#include <demo_interfaces/msg/hsb.h>
#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rclc/executor.h>
#include <rclc/rclc.h>
#include <rmw_microros/rmw_microros.h>

static const char *TAG = "microros_hsb";

/* A failed micro-ROS call ends the node's task with a log line naming the call. */
#define RCCHECK(call)                                                                   \
    do {                                                                                \
        rcl_ret_t rc_ = (call);                                                         \
        if (rc_ != RCL_RET_OK) {                                                        \
            ESP_LOGE(TAG, "%s failed with %d (line %d)", #call, (int)rc_, __LINE__);    \
            vTaskDelete(NULL);                                                          \
        }                                                                               \
    } while (0)
#define RCSOFTCHECK(call)                                                               \
    do {                                                                                \
        rcl_ret_t rc_ = (call);                                                         \
        if (rc_ != RCL_RET_OK) {                                                        \
            ESP_LOGW(TAG, "%s failed with %d", #call, (int)rc_);                        \
        }                                                                               \
    } while (0)

/* ---------------------------------------------------------------------------------------------
 * Wi-Fi station: connect, and reconnect whenever the access point drops us. */

#define WIFI_CONNECTED BIT0
static EventGroupHandle_t wifi_events;

static void on_wifi_event(void *arg, esp_event_base_t base, int32_t id, void *data)
{
    (void)arg;
    (void)data;
    if (base == WIFI_EVENT && (id == WIFI_EVENT_STA_START || id == WIFI_EVENT_STA_DISCONNECTED)) {
        xEventGroupClearBits(wifi_events, WIFI_CONNECTED);
        esp_wifi_connect();
    } else if (base == IP_EVENT && id == IP_EVENT_STA_GOT_IP) {
        xEventGroupSetBits(wifi_events, WIFI_CONNECTED);
    }
}

static void wifi_connect(void)
{
    wifi_events = xEventGroupCreate();
    ESP_ERROR_CHECK(esp_netif_init());
    ESP_ERROR_CHECK(esp_event_loop_create_default());
    esp_netif_create_default_wifi_sta();
    wifi_init_config_t init = WIFI_INIT_CONFIG_DEFAULT();
    ESP_ERROR_CHECK(esp_wifi_init(&init));
    ESP_ERROR_CHECK(esp_event_handler_register(WIFI_EVENT, ESP_EVENT_ANY_ID, on_wifi_event, NULL));
    ESP_ERROR_CHECK(esp_event_handler_register(IP_EVENT, IP_EVENT_STA_GOT_IP, on_wifi_event, NULL));
    wifi_config_t config = {0};
    strlcpy((char *)config.sta.ssid, CONFIG_UROS_WIFI_SSID, sizeof config.sta.ssid);
    strlcpy((char *)config.sta.password, CONFIG_UROS_WIFI_PASSWORD, sizeof config.sta.password);
    ESP_ERROR_CHECK(esp_wifi_set_mode(WIFI_MODE_STA));
    ESP_ERROR_CHECK(esp_wifi_set_config(WIFI_IF_STA, &config));
    ESP_ERROR_CHECK(esp_wifi_start());
    ESP_LOGI(TAG, "connecting to %s", CONFIG_UROS_WIFI_SSID);
    xEventGroupWaitBits(wifi_events, WIFI_CONNECTED, pdFALSE, pdTRUE, portMAX_DELAY);
}

/* ---------------------------------------------------------------------------------------------
 * The node: the LED's colour out, new colours in. */

static rcl_publisher_t state_publisher;
static rcl_subscription_t command_subscription;
static demo_interfaces__msg__Hsb state = {.hue = 30, .saturation = 100, .brightness = 50};
static demo_interfaces__msg__Hsb command;

static void on_state_timer(rcl_timer_t *timer, int64_t last_call_time)
{
    (void)last_call_time;
    if (timer != NULL) {
        RCSOFTCHECK(rcl_publish(&state_publisher, &state, NULL));
    }
}

static void on_command(const void *message)
{
    const demo_interfaces__msg__Hsb *hsb = message;
    state.hue = hsb->hue % 360;
    state.saturation = hsb->saturation > 100 ? 100 : hsb->saturation;
    state.brightness = hsb->brightness > 100 ? 100 : hsb->brightness;
    /* A real board drives its LED strip here (led_strip component, RMT). */
    ESP_LOGI(TAG, "LED now HSB %u,%u,%u", state.hue, state.saturation, state.brightness);
}

static void micro_ros_task(void *arg)
{
    (void)arg;
    rcl_allocator_t allocator = rcl_get_default_allocator();
    rcl_init_options_t init_options = rcl_get_zero_initialized_init_options();
    RCCHECK(rcl_init_options_init(&init_options, allocator));
    rmw_init_options_t *rmw_options = rcl_init_options_get_rmw_init_options(&init_options);
    RCCHECK(rmw_uros_options_set_udp_address(CONFIG_UROS_AGENT_IP, CONFIG_UROS_AGENT_PORT, rmw_options));

    rclc_support_t support;
    RCCHECK(rclc_support_init_with_options(&support, 0, NULL, &init_options, &allocator));
    rcl_node_t node;
    RCCHECK(rclc_node_init_default(&node, CONFIG_UROS_NODE_NAME, "", &support));

    const rosidl_message_type_support_t *hsb = ROSIDL_GET_MSG_TYPE_SUPPORT(demo_interfaces, msg, Hsb);
    RCCHECK(rclc_publisher_init_default(&state_publisher, &node, hsb, "state/led/hsb"));
    ESP_LOGI(TAG, "publishing on state/led/hsb every %d ms", CONFIG_UROS_STATE_PERIOD_MS);
    RCCHECK(rclc_subscription_init_default(&command_subscription, &node, hsb, "command/led/hsb"));
    rcl_timer_t timer;
    RCCHECK(rclc_timer_init_default(&timer, &support, RCL_MS_TO_NS(CONFIG_UROS_STATE_PERIOD_MS), on_state_timer));

    rclc_executor_t executor = rclc_executor_get_zero_initialized_executor();
    RCCHECK(rclc_executor_init(&executor, &support.context, 2, &allocator));
    RCCHECK(rclc_executor_add_timer(&executor, &timer));
    RCCHECK(rclc_executor_add_subscription(&executor, &command_subscription, &command, on_command, ON_NEW_DATA));
    for (;;) {
        rclc_executor_spin_some(&executor, RCL_MS_TO_NS(100));
        vTaskDelay(pdMS_TO_TICKS(10));
    }
}

void app_main(void)
{
    esp_err_t err = nvs_flash_init(); /* Wi-Fi keeps its calibration in NVS */
    if (err == ESP_ERR_NVS_NO_FREE_PAGES || err == ESP_ERR_NVS_NEW_VERSION_FOUND) {
        ESP_ERROR_CHECK(nvs_flash_erase());
        err = nvs_flash_init();
    }
    ESP_ERROR_CHECK(err);
    wifi_connect();
    /* micro-ROS's executor and the XRCE-DDS session buffers live on this task's stack. */
    xTaskCreate(micro_ros_task, "micro_ros", 16000, NULL, 5, NULL);
}
