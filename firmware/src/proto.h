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

/* Sync bytes, version, message types, NAK reasons, fault and module bits,
 * and the code table come from the generated header (bhr/protocol.py and
 * bhr/_kinematics/codetable.py is their single source; see bhr/_hardware/firmware_header.py). */
#include "bhr_gen.h"

#define PROTO_MAX_FRAME (PROTO_HEADER_LEN + PROTO_MAX_PAYLOAD + PROTO_CRC_LEN)

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
