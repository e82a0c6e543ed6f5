/*
 * proto.h - bhr serial protocol, version 1 (docs/protocol.md).
 *
 * Portable C99: the same file builds for the ATmega328P and for the host
 * unit tests and fuzzer. No dynamic memory, no I/O.
 *
 * Frame:  A5 5A | ver | type | seq | len | payload[len] | crc_hi crc_lo
 * CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no xorout)
 * over ver..payload, sent high byte first.
 */
#ifndef BHR_PROTO_H
#define BHR_PROTO_H

#include <stdint.h>

#define PROTO_SYNC0 0xA5u
#define PROTO_SYNC1 0x5Au
#define PROTO_VERSION 1u
#define PROTO_HEADER_LEN 6u
#define PROTO_CRC_LEN 2u
#define PROTO_MAX_PAYLOAD 64u
#define PROTO_MAX_FRAME (PROTO_HEADER_LEN + PROTO_MAX_PAYLOAD + PROTO_CRC_LEN)

/* Message types: host -> board */
#define MSG_SET_CODES 0x01u
#define MSG_STATUS 0x02u
#define MSG_STOP_ALL 0x03u
#define MSG_HEARTBEAT 0x04u
/* board -> host */
#define MSG_ACK 0x81u
#define MSG_NAK 0x82u
#define MSG_STATUS_REPLY 0x83u

/* NAK reasons */
#define NAK_BAD_CRC 0x01u
#define NAK_BAD_VERSION 0x02u
#define NAK_BAD_TYPE 0x03u
#define NAK_BAD_LENGTH 0x04u
#define NAK_BAD_COUNT 0x05u
#define NAK_BAD_CODE 0x06u
#define NAK_INCOMPLETE 0x07u

/* Fault flags (status reply byte 0, ACK byte 1) */
#define FAULT_SILENCE 0x01u  /* outputs were switched off: host fell silent */
#define FAULT_OVERHEAT 0x02u /* an actuator reached its on-time limit (latched) */
#define FAULT_COOLING 0x04u  /* a module is held off while it cools down */

/* Per-module byte of the status reply: low nibble = code on the outputs */
#define MODULE_OVERHEAT 0x10u
#define MODULE_COOLING 0x20u

uint16_t proto_crc16(uint16_t crc, const uint8_t *data, uint16_t n);
#define PROTO_CRC_INIT 0xFFFFu

/* Encode a frame into out (room for PROTO_MAX_FRAME bytes). Returns its
 * length, or 0 when len > PROTO_MAX_PAYLOAD. */
uint8_t proto_encode(uint8_t *out, uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len);

/* 1 when code is one of the six stable codes 0, 3, 6, 9, 12, 15. */
uint8_t proto_code_valid(uint8_t code);

typedef struct {
    uint8_t version;
    uint8_t type;
    uint8_t seq;
    uint8_t len;
    const uint8_t *payload; /* valid only during the callback */
} proto_frame_t;

/* Parser events */
#define PROTO_EV_FRAME 1      /* a frame with a good CRC */
#define PROTO_EV_BAD_CRC 2    /* header looked right, CRC did not match */
#define PROTO_EV_INCOMPLETE 3 /* header complete, rest never came (see expire) */

typedef void (*proto_handler_t)(void *ctx, uint8_t event, const proto_frame_t *frame);

typedef struct {
    uint8_t buf[PROTO_MAX_FRAME];
    uint8_t n;
    uint16_t dropped; /* bytes discarded while hunting for a frame (saturating) */
} proto_parser_t;

void proto_parser_init(proto_parser_t *p);
/* Feed one received byte; calls h for every event it completes (0..n). */
void proto_parser_feed(proto_parser_t *p, uint8_t byte, proto_handler_t h, void *ctx);
/* 1 when bytes of an unfinished frame are buffered. */
uint8_t proto_parser_pending(const proto_parser_t *p);
/* The line has been idle too long: drop the unfinished frame (one
 * PROTO_EV_INCOMPLETE event if its header was complete) and rescan the
 * bytes after its sync for frames. Leaves the buffer empty. */
void proto_parser_expire(proto_parser_t *p, proto_handler_t h, void *ctx);

#endif
