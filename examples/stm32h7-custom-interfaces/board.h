#ifndef BOARD_H
#define BOARD_H
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <uxr/client/transport.h>

bool board_transport_open(struct uxrCustomTransport *transport);
bool board_transport_close(struct uxrCustomTransport *transport);
size_t board_transport_write(struct uxrCustomTransport *transport, const uint8_t *buf, size_t len, uint8_t *err);
size_t board_transport_read(struct uxrCustomTransport *transport, uint8_t *buf, size_t len, int timeout,
                            uint8_t *err);
#endif
