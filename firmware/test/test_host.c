/*
 * test_host.c - unit tests and fuzzer for the portable firmware core
 * (proto.c, board.c), built for the host by `make -C firmware host-test`.
 *
 *   test_host [FUZZ_FRAMES [SEED]]     (defaults: 120000 random or mutated frames, seed 20240601)
 *
 * Exit status 0 when every check passes; the first failure prints one line
 * and exits 1. The fuzzer feeds random and mutated frames through the parser
 * into the board, with random time steps and idle gaps, and checks after
 * every event that only stable codes are on the output model, that NAKed
 * or corrupted frames change nothing, and that every reply is a well-formed
 * frame.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board.h"
#include "config.h"
#include "proto.h"

static unsigned long checks;

#define CHECK(cond, ...)                                                                 \
    do {                                                                                 \
        checks++;                                                                        \
        if (!(cond)) {                                                                   \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);                         \
            fprintf(stderr, __VA_ARGS__);                                                \
            fputc('\n', stderr);                                                         \
            exit(1);                                                                     \
        }                                                                                \
    } while (0)

/* ---- deterministic PRNG (xorshift64*) ---- */
static unsigned long long rng_state = 20240601ULL;
static unsigned rnd(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (unsigned)((rng_state * 2685821657736338717ULL) >> 32);
}
static unsigned rnd_below(unsigned n) { return n ? rnd() % n : 0; }

static const uint8_t VALID[6] = {0, 3, 6, 9, 12, 15};

/* ---- a harness that records what the board answered ---- */
typedef struct {
    board_t *b;
    int frames, bad_crc, incomplete;
    int replies;
    uint8_t last_reply[PROTO_MAX_FRAME];
    uint8_t last_reply_len;
    int check_invariants; /* fuzz mode */
} ctx_t;

static void check_outputs(const board_t *b, const char *where)
{
    uint8_t chain[BHR_CHIPS];
    board_chain(b, chain);
    for (int m = 0; m < BHR_MODULES; m++) {
        uint8_t c = (uint8_t)((chain[m / 2] >> ((m & 1) * 4)) & 0x0F);
        CHECK(proto_code_valid(c), "%s: module %d shows unstable code %d", where, m + 1, c);
        CHECK(proto_code_valid(b->output[m]), "%s: output[%d] = %d", where, m + 1, b->output[m]);
        if (b->module_flags[m] & MODULE_COOLING)
            CHECK(c == 0, "%s: module %d is cooling but shows %d", where, m + 1, c);
    }
    if (BHR_MODULES & 1)
        CHECK((chain[BHR_CHIPS - 1] >> 4) == 0, "%s: unused outputs set", where);
    if (!b->enabled)
        for (int k = 0; k < BHR_CHIPS; k++)
            CHECK(chain[k] == 0, "%s: outputs on while disabled", where);
}

/* parse a reply with a fresh parser: exactly one good frame */
static int reply_frames;
static proto_frame_t reply_frame;
static uint8_t reply_payload[PROTO_MAX_PAYLOAD];
static void reply_handler(void *c, uint8_t ev, const proto_frame_t *f)
{
    (void)c;
    CHECK(ev == PROTO_EV_FRAME, "reply parsed as event %d", ev);
    reply_frames++;
    reply_frame = *f;
    memcpy(reply_payload, f->payload, f->len);
    reply_frame.payload = reply_payload;
}
static const proto_frame_t *parse_reply(const uint8_t *r, uint8_t n)
{
    proto_parser_t p;
    proto_parser_init(&p);
    reply_frames = 0;
    for (uint8_t i = 0; i < n; i++)
        proto_parser_feed(&p, r[i], reply_handler, NULL);
    CHECK(reply_frames == 1 && !proto_parser_pending(&p), "reply is not exactly one frame (%d)", reply_frames);
    return &reply_frame;
}

static void handler(void *vc, uint8_t ev, const proto_frame_t *f)
{
    ctx_t *c = (ctx_t *)vc;
    board_t before = *c->b;
    uint8_t reply[PROTO_MAX_FRAME];
    if (ev == PROTO_EV_FRAME)
        c->frames++;
    else if (ev == PROTO_EV_BAD_CRC)
        c->bad_crc++;
    else if (ev == PROTO_EV_INCOMPLETE)
        c->incomplete++;
    CHECK(f->len <= PROTO_MAX_PAYLOAD, "frame length %d", f->len);
    uint8_t n = board_handle(c->b, ev, f, reply);
    CHECK(n > 0 && n <= PROTO_MAX_FRAME, "reply length %d", n);
    memcpy(c->last_reply, reply, n);
    c->last_reply_len = n;
    c->replies++;
    if (!c->check_invariants)
        return;
    const proto_frame_t *r = parse_reply(reply, n);
    CHECK(r->seq == f->seq, "reply seq %d for frame seq %d", r->seq, f->seq);
    check_outputs(c->b, "after frame");
    if (r->type == MSG_NAK) {
        CHECK(r->len == 3, "NAK length %d", r->len);
        CHECK(r->payload[1] >= NAK_BAD_CRC && r->payload[1] <= NAK_INCOMPLETE, "NAK reason %d", r->payload[1]);
        CHECK(memcmp(&before, c->b, sizeof(before)) == 0, "a NAKed frame changed the board (reason %d)",
              r->payload[1]);
    } else {
        CHECK(ev == PROTO_EV_FRAME, "answered a corrupt frame with type %02x", r->type);
        if (f->type == MSG_SET_CODES) {
            CHECK(r->type == MSG_ACK, "SET_CODES answered with %02x", r->type);
            for (int m = 0; m < BHR_MODULES; m++) {
                uint8_t want = (c->b->module_flags[m] & MODULE_COOLING) ? 0 : f->payload[1 + m];
                CHECK(c->b->output[m] == want, "module %d shows %d, sent %d", m + 1, c->b->output[m], want);
            }
        }
        if (f->type == MSG_STATUS)
            CHECK(r->type == MSG_STATUS_REPLY && r->len == 3 + BHR_MODULES, "bad status reply");
        if (f->type == MSG_STOP_ALL)
            for (int m = 0; m < BHR_MODULES; m++)
                CHECK(c->b->output[m] == 0, "module %d on after stop-all", m + 1);
    }
}

static void feed(proto_parser_t *p, ctx_t *c, const uint8_t *data, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        proto_parser_feed(p, data[i], handler, c);
        CHECK(p->n < PROTO_MAX_FRAME, "parser buffer at %d", p->n);
    }
}

static uint8_t set_codes_frame(uint8_t *out, uint8_t seq, const uint8_t *codes, uint8_t count)
{
    uint8_t payload[PROTO_MAX_PAYLOAD];
    payload[0] = count;
    memcpy(payload + 1, codes, count);
    return proto_encode(out, MSG_SET_CODES, seq, payload, (uint8_t)(count + 1));
}

/* ---------------------------------------------------------------- unit tests */

static void test_crc(void)
{
    const uint8_t v[] = "123456789";
    CHECK(proto_crc16(PROTO_CRC_INIT, v, 9) == 0x29B1, "CRC-16/CCITT-FALSE('123456789') = %04x, want 29b1",
          proto_crc16(PROTO_CRC_INIT, v, 9));
    /* the heartbeat frame with seq 7, as printed in docs/protocol.md */
    uint8_t f[PROTO_MAX_FRAME];
    uint8_t n = proto_encode(f, MSG_HEARTBEAT, 7, NULL, 0);
    const uint8_t want[] = {0xA5, 0x5A, 0x01, 0x04, 0x07, 0x00, 0x00, 0x00};
    CHECK(n == 8 && memcmp(f, want, 6) == 0, "heartbeat header");
    uint16_t crc = proto_crc16(PROTO_CRC_INIT, f + 2, 4);
    CHECK(f[6] == (crc >> 8) && f[7] == (crc & 0xFF), "CRC placed high byte first");
}

static void test_codes(void)
{
    for (int c = 0; c < 256; c++) {
        int valid = c == 0 || c == 3 || c == 6 || c == 9 || c == 12 || c == 15;
        CHECK(proto_code_valid((uint8_t)c) == valid, "proto_code_valid(%d)", c);
    }
}

static void test_parser_resync(void)
{
    board_t b;
    board_init(&b);
    ctx_t c = {.b = &b, .check_invariants = 1};
    proto_parser_t p;
    proto_parser_init(&p);
    uint8_t f[PROTO_MAX_FRAME];
    uint8_t codes[BHR_MODULES];
    for (int m = 0; m < BHR_MODULES; m++)
        codes[m] = VALID[(m + 1) % 6];
    uint8_t n = set_codes_frame(f, 1, codes, BHR_MODULES);

    /* noise, including sync bytes, then a frame */
    const uint8_t noise[] = {0x00, 0xA5, 0xA5, 0x13, 0x5A, 0xA5, 0x5A, 0x01, 0x01, 0x09, 0xFF};
    feed(&p, &c, noise, sizeof(noise));
    feed(&p, &c, f, n);
    /* the noise ended in a false header with len 0xFF: dropped silently, frame found */
    CHECK(c.frames == 1, "frame after noise: %d frames", c.frames);
    CHECK(memcmp(b.output, codes, BHR_MODULES) == 0, "codes applied after noise");

    /* corrupted frame: one bit flipped in the payload -> NAK bad CRC, nothing changes */
    uint8_t g[PROTO_MAX_FRAME];
    memcpy(g, f, n);
    g[7] ^= 0x04;
    board_t before = b;
    int crc0 = c.bad_crc;
    feed(&p, &c, g, n);
    CHECK(c.bad_crc == crc0 + 1, "corrupt frame reported");
    CHECK(memcmp(&before, &b, sizeof(b)) == 0, "corrupt frame changed state");
    const proto_frame_t *r = parse_reply(c.last_reply, c.last_reply_len);
    CHECK(r->type == MSG_NAK && r->payload[1] == NAK_BAD_CRC && r->seq == 1, "NAK bad CRC");

    /* truncated frame followed by a good one: the good one still gets through */
    uint8_t codes2[BHR_MODULES] = {0};
    codes2[0] = 15;
    uint8_t n2 = set_codes_frame(g, 2, codes2, BHR_MODULES);
    int frames0 = c.frames;
    feed(&p, &c, f, (size_t)(n - 3));
    feed(&p, &c, g, n2);
    if (c.frames == frames0) { /* swallowed by the truncated frame's length: the gap rescues it */
        proto_parser_expire(&p, handler, &c);
    }
    CHECK(c.frames == frames0 + 1, "frame after a truncated one");
    CHECK(b.output[0] == 15, "codes of the frame after a truncated one");
    CHECK(!proto_parser_pending(&p), "parser empty");

    /* header then silence: expire NAKs "incomplete" with the header's seq */
    feed(&p, &c, f, 7);
    CHECK(proto_parser_pending(&p), "partial frame pending");
    int inc0 = c.incomplete;
    proto_parser_expire(&p, handler, &c);
    CHECK(c.incomplete == inc0 + 1 && !proto_parser_pending(&p), "expire");
    r = parse_reply(c.last_reply, c.last_reply_len);
    CHECK(r->type == MSG_NAK && r->payload[1] == NAK_INCOMPLETE && r->seq == 1, "NAK incomplete");

    /* two frames back to back in one burst */
    frames0 = c.frames;
    uint8_t burst[2 * PROTO_MAX_FRAME];
    memcpy(burst, f, n);
    memcpy(burst + n, g, n2);
    feed(&p, &c, burst, (size_t)n + n2);
    CHECK(c.frames == frames0 + 2, "burst of two frames");
}

static uint8_t send(board_t *b, const uint8_t *frame, uint8_t n, const proto_frame_t **reply)
{
    static ctx_t c;
    memset(&c, 0, sizeof(c));
    c.b = b;
    c.check_invariants = 1;
    proto_parser_t p;
    proto_parser_init(&p);
    feed(&p, &c, frame, n);
    CHECK(c.replies == 1, "one reply, got %d", c.replies);
    *reply = parse_reply(c.last_reply, c.last_reply_len);
    return (*reply)->type;
}

static void test_board(void)
{
    board_t b;
    board_init(&b);
    uint8_t f[PROTO_MAX_FRAME];
    const proto_frame_t *r;
    uint8_t codes[BHR_MODULES] = {0};
    codes[0] = 3;
    if (BHR_MODULES > 2)
        codes[2] = 6;

    /* status of a fresh board: everything off, no fault */
    uint8_t n = proto_encode(f, MSG_STATUS, 9, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_STATUS_REPLY, "status reply");
    CHECK(r->payload[0] == 0 && r->payload[1] == 0 && r->payload[2] == BHR_MODULES, "fresh status");

    /* set codes */
    n = set_codes_frame(f, 10, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && r->payload[0] == MSG_SET_CODES, "ACK set codes");
    CHECK(b.enabled && memcmp(b.output, codes, BHR_MODULES) == 0, "codes on");
    uint8_t chain[BHR_CHIPS];
    board_chain(&b, chain);
    CHECK(chain[0] == 3, "module 1 in the low nibble of chip 1 (%02x)", chain[0]);
    if (BHR_MODULES > 2)
        CHECK(chain[1] == 6, "module 3 in the low nibble of chip 2 (%02x)", chain[1]);

    /* an invalid code anywhere: NAK naming the module, nothing changes */
    uint8_t bad[BHR_MODULES];
    memcpy(bad, codes, BHR_MODULES);
    bad[BHR_MODULES - 1] = 5;
    board_t before = b;
    n = set_codes_frame(f, 11, bad, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_NAK, "NAK bad code");
    CHECK(r->payload[0] == MSG_SET_CODES && r->payload[1] == NAK_BAD_CODE && r->payload[2] == BHR_MODULES,
          "NAK names module %d", r->payload[2]);
    CHECK(memcmp(&before, &b, sizeof(b)) == 0, "bad code changed nothing");

    /* wrong module count */
    if (BHR_MODULES < 32) {
        uint8_t more[BHR_MODULES + 1];
        memset(more, 0, sizeof(more));
        n = set_codes_frame(f, 12, more, BHR_MODULES + 1);
        CHECK(send(&b, f, n, &r) == MSG_NAK && r->payload[1] == NAK_BAD_COUNT && r->payload[2] == BHR_MODULES,
              "NAK bad count");
    }
    /* count byte disagreeing with the length */
    uint8_t p2[3] = {5, 0, 0};
    n = proto_encode(f, MSG_SET_CODES, 13, p2, 3);
    CHECK(send(&b, f, n, &r) == MSG_NAK && r->payload[1] == NAK_BAD_LENGTH, "NAK bad length");
    /* unknown type, other version */
    n = proto_encode(f, 0x42, 14, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_NAK && r->payload[1] == NAK_BAD_TYPE, "NAK bad type");
    n = proto_encode(f, MSG_HEARTBEAT, 15, NULL, 0);
    f[2] = 2;
    uint16_t crc = proto_crc16(PROTO_CRC_INIT, f + 2, 4);
    f[6] = (uint8_t)(crc >> 8);
    f[7] = (uint8_t)crc;
    CHECK(send(&b, f, n, &r) == MSG_NAK && r->payload[1] == NAK_BAD_VERSION && r->payload[2] == 1,
          "NAK bad version");
    CHECK(memcmp(&before, &b, sizeof(b)) == 0, "NAKs changed nothing");

    /* heartbeats keep the outputs on; silence switches them off */
    uint16_t hb_step = (uint16_t)(BHR_SILENCE_MS * 3 / 4 < BHR_ON_MAX_MS / 4 ? BHR_SILENCE_MS * 3 / 4
                                                                             : BHR_ON_MAX_MS / 4);
    for (int i = 0; i < 3; i++) { /* longer than the silence timeout, shorter than the on-time limit */
        board_tick(&b, hb_step);
        n = proto_encode(f, MSG_HEARTBEAT, (uint8_t)(20 + i), NULL, 0);
        CHECK(send(&b, f, n, &r) == MSG_ACK, "heartbeat ACK");
    }
    CHECK(b.enabled && b.output[0] == 3 && !board_faults(&b), "heartbeats kept the outputs on");
    /* ... but only within the thermal limit, so start over */
    n = proto_encode(f, MSG_STOP_ALL, 30, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK, "stop ACK");
    for (int i = 0; i < 1000; i++)
        board_tick(&b, 100); /* cool everything */
    n = set_codes_frame(f, 31, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK, "codes again");
    board_tick(&b, (uint16_t)(BHR_SILENCE_MS - 1));
    board_tick(&b, 1);
    CHECK(b.enabled && b.output[0] == 3, "still on at the silence timeout");
    board_tick(&b, 1);
    CHECK(!b.enabled && b.output[0] == 0 && (board_faults(&b) & FAULT_SILENCE), "off at the silence timeout");
    check_outputs(&b, "silence");
    n = proto_encode(f, MSG_STATUS, 32, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_STATUS_REPLY && (r->payload[0] & FAULT_SILENCE) && r->payload[3] == 0,
          "status after silence");
    n = proto_encode(f, MSG_HEARTBEAT, 33, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.output[0] == 0, "a heartbeat does not switch back on");
    n = set_codes_frame(f, 34, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.output[0] == 3 && !(board_faults(&b) & FAULT_SILENCE),
          "codes switch back on and clear the silence fault");

    /* thermal limit: module 1 held on past BHR_ON_MAX_MS with heartbeats */
    unsigned long t = 0;
    while (b.output[0] == 3 && t < 10UL * BHR_ON_MAX_MS) {
        board_tick(&b, 10);
        t += 10;
        if (t % (BHR_SILENCE_MS / 2) < 10) {
            n = proto_encode(f, MSG_HEARTBEAT, 35, NULL, 0);
            send(&b, f, n, &r);
        }
        n = set_codes_frame(f, 36, codes, BHR_MODULES); /* host keeps asking for it */
        if (t % 100 == 0)
            send(&b, f, n, &r);
    }
    /* the earlier on-time (before silence) counts too: heat drains slowly */
    CHECK(b.output[0] == 0 && t <= BHR_ON_MAX_MS, "module 1 switched off after %lu ms", t);
    CHECK(board_faults(&b) & FAULT_OVERHEAT, "overheat fault");
    CHECK(b.module_flags[0] == (MODULE_OVERHEAT | MODULE_COOLING), "module 1 flags %02x", b.module_flags[0]);
    if (BHR_MODULES > 2)
        CHECK(b.output[2] == 6 || (b.module_flags[2] & MODULE_COOLING), "other modules unaffected");
    check_outputs(&b, "overheat");
    n = proto_encode(f, MSG_STATUS, 37, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_STATUS_REPLY && (r->payload[0] & (FAULT_OVERHEAT | FAULT_COOLING)) &&
              r->payload[3] == (MODULE_OVERHEAT | MODULE_COOLING),
          "status reports the overheat");
    /* cools down within BHR_COOLDOWN_MS, then follows the host again */
    uint8_t zero[BHR_MODULES] = {0};
    n = set_codes_frame(f, 38, zero, BHR_MODULES);
    send(&b, f, n, &r);
    t = 0;
    while ((b.module_flags[0] & MODULE_COOLING) && t < 2UL * BHR_COOLDOWN_MS) {
        board_tick(&b, 10);
        t += 10;
        if (t % 100 == 0)
            send(&b, f, n, &r);
    }
    CHECK(t <= BHR_COOLDOWN_MS + 10, "cooled after %lu ms", t);
    n = set_codes_frame(f, 39, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.output[0] == 3, "module 1 back on after cool-down");
    CHECK(board_faults(&b) & FAULT_OVERHEAT, "overheat stays latched until stop-all");
    n = proto_encode(f, MSG_STOP_ALL, 40, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK && !b.enabled && !(board_faults(&b) & FAULT_OVERHEAT), "stop-all clears");
    check_outputs(&b, "stop");
}

/* ---------------------------------------------------------------- fuzzer */

static uint8_t random_valid_frame(uint8_t *out, uint8_t *is_set_codes)
{
    uint8_t seq = (uint8_t)rnd();
    unsigned kind = rnd_below(10);
    *is_set_codes = 0;
    if (kind < 6) {
        uint8_t codes[BHR_MODULES];
        for (int m = 0; m < BHR_MODULES; m++)
            codes[m] = VALID[rnd_below(6)];
        *is_set_codes = 1;
        return set_codes_frame(out, seq, codes, BHR_MODULES);
    }
    static const uint8_t types[] = {MSG_STATUS, MSG_STOP_ALL, MSG_HEARTBEAT, MSG_STATUS};
    return proto_encode(out, types[kind - 6], seq, NULL, 0);
}

static size_t mutate(uint8_t *buf, size_t n, size_t cap)
{
    unsigned ops = 1 + rnd_below(4);
    for (unsigned i = 0; i < ops; i++) {
        switch (rnd_below(9)) {
        case 0: /* flip a bit */
            if (n)
                buf[rnd_below((unsigned)n)] ^= (uint8_t)(1u << rnd_below(8));
            break;
        case 1: /* random byte */
            if (n)
                buf[rnd_below((unsigned)n)] = (uint8_t)rnd();
            break;
        case 2: /* insert a byte */
            if (n < cap) {
                size_t at = rnd_below((unsigned)n + 1);
                memmove(buf + at + 1, buf + at, n - at);
                buf[at] = (uint8_t)rnd();
                n++;
            }
            break;
        case 3: /* delete a byte */
            if (n) {
                size_t at = rnd_below((unsigned)n);
                memmove(buf + at, buf + at + 1, n - at - 1);
                n--;
            }
            break;
        case 4: /* truncate */
            n = rnd_below((unsigned)n + 1);
            break;
        case 5: { /* an invalid code with a correct CRC (payload and CRC recomputed) */
            if (n >= 8 && buf[3] == MSG_SET_CODES && buf[5] >= 1 && (size_t)(6 + buf[5] + 2) <= n) {
                uint8_t len = buf[5];
                buf[6 + 1 + rnd_below(len > 1 ? len - 1u : 1u)] = (uint8_t)rnd_below(16);
                uint16_t crc = proto_crc16(PROTO_CRC_INIT, buf + 2, (uint16_t)(4 + len));
                buf[6 + len] = (uint8_t)(crc >> 8);
                buf[7 + len] = (uint8_t)crc;
            }
            break;
        }
        case 6: { /* valid CRC on a random header: type, version, count, length */
            if (n >= 8) {
                uint8_t len = (uint8_t)rnd_below((unsigned)(n - 8) + 1);
                if (len > PROTO_MAX_PAYLOAD)
                    len = PROTO_MAX_PAYLOAD;
                buf[0] = PROTO_SYNC0;
                buf[1] = PROTO_SYNC1;
                if (rnd_below(4) == 0)
                    buf[2] = (uint8_t)rnd_below(4);
                if (rnd_below(2) == 0)
                    buf[3] = (uint8_t)rnd();
                buf[5] = len;
                if (len && rnd_below(2))
                    buf[6] = (uint8_t)rnd_below(40);
                uint16_t crc = proto_crc16(PROTO_CRC_INIT, buf + 2, (uint16_t)(4 + len));
                buf[6 + len] = (uint8_t)(crc >> 8);
                buf[7 + len] = (uint8_t)crc;
                n = (size_t)len + 8;
            }
            break;
        }
        case 7: /* duplicate the frame */
            if (2 * n <= cap) {
                memcpy(buf + n, buf, n);
                n *= 2;
            }
            break;
        default: /* leading noise */
            if (n + 3 <= cap) {
                memmove(buf + 3, buf, n);
                buf[0] = (uint8_t)rnd();
                buf[1] = rnd_below(2) ? PROTO_SYNC0 : (uint8_t)rnd();
                buf[2] = rnd_below(2) ? PROTO_SYNC1 : (uint8_t)rnd();
                n += 3;
            }
            break;
        }
    }
    return n;
}

static void fuzz(unsigned long count)
{
    board_t b;
    board_init(&b);
    ctx_t c = {.b = &b, .check_invariants = 1};
    proto_parser_t p;
    proto_parser_init(&p);
    uint8_t buf[4 * PROTO_MAX_FRAME];
    unsigned long mutated = 0, random_blobs = 0, clean = 0, liveness = 0;
    unsigned long long bytes = 0;
    while (mutated + random_blobs < count) {
        uint8_t is_set = 0;
        size_t n;
        unsigned kind = rnd_below(10);
        if (kind < 2) { /* random bytes, biased toward sync bytes */
            n = 1 + rnd_below(PROTO_MAX_FRAME);
            for (size_t k = 0; k < n; k++) {
                unsigned r = rnd_below(8);
                buf[k] = r == 0 ? PROTO_SYNC0 : r == 1 ? PROTO_SYNC1 : (uint8_t)rnd();
            }
            random_blobs++;
        } else if (kind < 8) {
            n = random_valid_frame(buf, &is_set);
            n = mutate(buf, n, sizeof(buf));
            mutated++;
        } else {
            n = random_valid_frame(buf, &is_set);
            clean++;
        }
        feed(&p, &c, buf, n);
        bytes += n;
        check_outputs(&b, "fuzz");
        /* time passes: short steps, sometimes an idle gap */
        unsigned step = rnd_below(4) ? rnd_below(20) : rnd_below(3000);
        board_tick(&b, (uint16_t)step);
        check_outputs(&b, "fuzz tick");
        if (rnd_below(8) == 0 || step >= BHR_FRAME_GAP_MS) {
            proto_parser_expire(&p, handler, &c);
            check_outputs(&b, "fuzz expire");
            /* liveness: after an idle gap a clean frame is always understood */
            if (rnd_below(4) == 0) {
                int frames0 = c.frames;
                n = random_valid_frame(buf, &is_set);
                feed(&p, &c, buf, n);
                bytes += n;
                CHECK(c.frames == frames0 + 1 && !proto_parser_pending(&p), "clean frame after a gap was lost");
                liveness++;
            }
        }
    }
    printf("fuzz: %lu random or mutated frames (%lu mutated, %lu random blobs), plus %lu clean frames and "
           "%lu liveness probes, %llu bytes; events: %d good frames, %d bad CRC, %d incomplete\n",
           mutated + random_blobs, mutated, random_blobs, clean, liveness, bytes, c.frames, c.bad_crc,
           c.incomplete);
    CHECK(c.frames > 0 && c.bad_crc > 0 && c.incomplete > 0, "fuzzer reached every event");
}

/* `test_host vectors`: frames for the Python side to compare with bhr.protocol */
static void print_hex(const char *name, const uint8_t *f, uint8_t n)
{
    printf("%s", name);
    for (uint8_t i = 0; i < n; i++)
        printf(" %02x", f[i]);
    printf("\n");
}

static int vectors(void)
{
    uint8_t f[PROTO_MAX_FRAME];
    const uint8_t digits[] = "123456789";
    printf("crc16_123456789 %04x\n", proto_crc16(PROTO_CRC_INIT, digits, 9));
    const uint8_t codes[5] = {3, 0, 6, 0, 0};
    print_hex("set_codes_seq0_3,0,6,0,0", f, set_codes_frame(f, 0, codes, 5));
    print_hex("status_seq1", f, proto_encode(f, MSG_STATUS, 1, NULL, 0));
    print_hex("stop_all_seq2", f, proto_encode(f, MSG_STOP_ALL, 2, NULL, 0));
    print_hex("heartbeat_seq7", f, proto_encode(f, MSG_HEARTBEAT, 7, NULL, 0));
    /* board replies, from a fresh board */
    board_t b;
    board_init(&b);
    proto_frame_t fr = {PROTO_VERSION, MSG_SET_CODES, 0, 6, NULL};
    uint8_t payload[6] = {5, 3, 0, 6, 0, 0};
    fr.payload = payload;
    if (BHR_MODULES == 5) {
        print_hex("ack_seq0", f, board_handle(&b, PROTO_EV_FRAME, &fr, f));
        fr.type = MSG_STATUS;
        fr.seq = 1;
        fr.len = 0;
        print_hex("status_reply_seq1", f, board_handle(&b, PROTO_EV_FRAME, &fr, f));
        fr.type = MSG_SET_CODES;
        fr.seq = 2;
        fr.len = 6;
        payload[4] = 5;
        print_hex("nak_bad_code_seq2", f, board_handle(&b, PROTO_EV_FRAME, &fr, f));
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "vectors") == 0)
        return vectors();
    unsigned long count = argc > 1 ? strtoul(argv[1], NULL, 10) : 120000UL;
    if (argc > 2)
        rng_state = strtoull(argv[2], NULL, 10) | 1ULL;
    printf("host tests: BHR_MODULES=%d silence=%lu ms on-max=%lu ms cool-down=%lu ms seed=%llu\n", BHR_MODULES,
           (unsigned long)BHR_SILENCE_MS, (unsigned long)BHR_ON_MAX_MS, (unsigned long)BHR_COOLDOWN_MS,
           rng_state);
    test_crc();
    test_codes();
    test_parser_resync();
    test_board();
    fuzz(count);
    printf("OK: %lu checks passed\n", checks);
    return 0;
}
