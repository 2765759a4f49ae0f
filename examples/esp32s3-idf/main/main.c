/* An ESP32-S3 micro-ROS node (seed 000, done with uros): joins Wi-Fi, then runs the node (../app/app.c:
 * reaches a micro-ROS agent over UDP, publishes the LED's colour as demo_interfaces/msg/Hsb on
 * state/led/hsb every CONFIG_UROS_STATE_PERIOD_MS and takes new colours from command/led/hsb) as a
 * FreeRTOS task. The same app.c runs in QEMU with `uros probe --app examples/esp32s3-idf/app`.
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

void appMain(void *arg); /* ../app/app.c: the node, shared with `uros probe --app` */

static const char *TAG = "microros_hsb";

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
    xTaskCreate(appMain, "micro_ros", 16000, NULL, 5, NULL);
}
