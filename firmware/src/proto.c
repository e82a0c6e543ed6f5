/* proto.c - framing, CRC and the resynchronising stream parser (see proto.h). */
#include "proto.h"

#include <string.h>

uint16_t proto_crc16(uint16_t crc, const uint8_t *data, uint16_t n)
{
    while (n--) {
        crc ^= (uint16_t)((uint16_t)*data++ << 8);
        for (uint8_t i = 0; i < 8; i++)
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
    return crc;
}

uint8_t proto_code_valid(uint8_t code)
{
    return code < 16u && ((BHR_VALID_CODE_MASK >> code) & 1u);
}

uint8_t proto_encode(uint8_t *out, uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len)
{
    if (len > PROTO_MAX_PAYLOAD)
        return 0;
    out[0] = PROTO_SYNC0;
    out[1] = PROTO_SYNC1;
    out[2] = PROTO_VERSION;
    out[3] = type;
    out[4] = seq;
    out[5] = len;
    if (len)
        memcpy(out + PROTO_HEADER_LEN, payload, len);
    uint16_t crc = proto_crc16(PROTO_CRC_INIT, out + 2, (uint16_t)(PROTO_HEADER_LEN - 2 + len));
    out[PROTO_HEADER_LEN + len] = (uint8_t)(crc >> 8);
    out[PROTO_HEADER_LEN + len + 1] = (uint8_t)(crc & 0xFFu);
    return (uint8_t)(PROTO_HEADER_LEN + len + PROTO_CRC_LEN);
}

void proto_parser_init(proto_parser_t *p)
{
    p->n = 0;
    p->dropped = 0;
}

uint8_t proto_parser_pending(const proto_parser_t *p)
{
    return p->n != 0;
}

static void drop(proto_parser_t *p, uint8_t k)
{
    if (k >= p->n) {
        k = p->n;
        p->n = 0;
    } else {
        memmove(p->buf, p->buf + k, (size_t)(p->n - k));
        p->n = (uint8_t)(p->n - k);
    }
    uint32_t d = (uint32_t)p->dropped + k;
    p->dropped = (uint16_t)(d > 0xFFFFu ? 0xFFFFu : d);
}

static void make_frame(const proto_parser_t *p, proto_frame_t *f)
{
    f->version = p->buf[2];
    f->type = p->buf[3];
    f->seq = p->buf[4];
    f->len = p->buf[5];
    f->payload = p->buf + PROTO_HEADER_LEN;
}

/* Consume every complete frame (or noise) at the front of the buffer. */
static void scan(proto_parser_t *p, proto_handler_t h, void *ctx)
{
    for (;;) {
        if (p->n == 0)
            return;
        if (p->buf[0] != PROTO_SYNC0) {
            uint8_t k = 1;
            while (k < p->n && p->buf[k] != PROTO_SYNC0)
                k++;
            drop(p, k);
            continue;
        }
        if (p->n < 2)
            return;
        if (p->buf[1] != PROTO_SYNC1) {
            drop(p, 1);
            continue;
        }
        if (p->n < PROTO_HEADER_LEN)
            return;
        uint8_t len = p->buf[5];
        if (len > PROTO_MAX_PAYLOAD) { /* cannot be a frame: silent resync */
            drop(p, 1);
            continue;
        }
        uint8_t total = (uint8_t)(PROTO_HEADER_LEN + len + PROTO_CRC_LEN);
        if (p->n < total)
            return;
        uint16_t want = proto_crc16(PROTO_CRC_INIT, p->buf + 2, (uint16_t)(PROTO_HEADER_LEN - 2 + len));
        uint16_t got = (uint16_t)(((uint16_t)p->buf[total - 2] << 8) | p->buf[total - 1]);
        proto_frame_t f;
        make_frame(p, &f);
        if (want == got) {
            h(ctx, PROTO_EV_FRAME, &f);
            /* drop without counting: these bytes were a frame */
            uint16_t d = p->dropped;
            drop(p, total);
            p->dropped = d;
        } else {
            h(ctx, PROTO_EV_BAD_CRC, &f);
            drop(p, 1); /* the real frame may start inside this one */
        }
    }
}

void proto_parser_feed(proto_parser_t *p, uint8_t byte, proto_handler_t h, void *ctx)
{
    if (p->n >= PROTO_MAX_FRAME) /* cannot happen: scan keeps n < total <= max */
        drop(p, 1);
    p->buf[p->n++] = byte;
    scan(p, h, ctx);
}

void proto_parser_expire(proto_parser_t *p, proto_handler_t h, void *ctx)
{
    uint8_t first = 1;
    while (p->n) {
        /* scan() left an unfinished candidate (or a lone sync byte) at the front */
        if (first && p->n >= PROTO_HEADER_LEN && p->buf[0] == PROTO_SYNC0 && p->buf[1] == PROTO_SYNC1) {
            proto_frame_t f;
            make_frame(p, &f);
            f.len = 0; /* payload never arrived */
            h(ctx, PROTO_EV_INCOMPLETE, &f);
        }
        first = 0;
        drop(p, 1);
        scan(p, h, ctx);
    }
}
