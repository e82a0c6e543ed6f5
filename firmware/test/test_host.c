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
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board.h"
#include "config.h"
#include "proto.h"
#include "ring.h"

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
        CHECK(proto_code_valid(b->drive[m]), "%s: drive[%d] = %d", where, m + 1, b->drive[m]);
        CHECK((c & ~b->drive[m]) == 0, "%s: module %d shows %d while driving %d", where, m + 1, c, b->drive[m]);
        CHECK((b->full[m] & ~b->drive[m]) == 0, "%s: module %d: full power on a wire it does not drive", where,
              m + 1);
        CHECK((b->drive[m] & b->cool[m]) == 0, "%s: module %d drives %d with a wire cooling (%d)", where, m + 1,
              b->drive[m], b->cool[m]);
        CHECK(!(b->module_flags[m] & MODULE_COOLING) == !b->cool[m], "%s: module %d cooling flag", where, m + 1);
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
                uint8_t want = (f->payload[1 + m] & before.cool[m]) ? 0 : f->payload[1 + m];
                uint8_t new_on = (uint8_t)(want & ~before.drive[m]);
                for (int k = 0; k < 4; k++)
                    if (((new_on >> k) & 1) && before.theta[m * 4 + k] > BHR_THETA_RELAX)
                        want = 0; /* a wire still relaxing: held off */
                CHECK(c->b->drive[m] == want, "module %d drives %d, sent %d", m + 1, c->b->drive[m], want);
            }
        }
        if (f->type == MSG_STATUS)
            CHECK(r->type == MSG_STATUS_REPLY && r->len == 3 + BHR_MODULES, "bad status reply");
        if (f->type == MSG_STOP_ALL)
            for (int m = 0; m < BHR_MODULES; m++)
                CHECK(c->b->drive[m] == 0 && c->b->shown[m] == 0, "module %d on after stop-all", m + 1);
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

/* A board after its power-up cool-down and a long idle time: every wire cold. */
static void ready_board(board_t *b)
{
    board_init(b);
    board_tick(b, 20000);
    CHECK(!(board_faults(b) & FAULT_COOLING), "board still cooling after 20 s");
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
    ready_board(&b);
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
    CHECK(memcmp(b.drive, codes, BHR_MODULES) == 0, "codes applied after noise");

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
    CHECK(b.drive[0] == 15, "codes of the frame after a truncated one");
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
    ready_board(&b);
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
    CHECK(b.enabled && memcmp(b.drive, codes, BHR_MODULES) == 0, "codes on");
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
    uint16_t hb_step = (uint16_t)(BHR_SILENCE_MS * 3 / 4);
    for (int i = 0; i < 3; i++) { /* longer than the silence timeout */
        board_tick(&b, hb_step);
        n = proto_encode(f, MSG_HEARTBEAT, (uint8_t)(20 + i), NULL, 0);
        CHECK(send(&b, f, n, &r) == MSG_ACK, "heartbeat ACK");
    }
    CHECK(b.enabled && b.drive[0] == 3 && !board_faults(&b), "heartbeats kept the outputs on");
    board_tick(&b, (uint16_t)(BHR_SILENCE_MS - 1));
    board_tick(&b, 1);
    CHECK(b.enabled && b.drive[0] == 3, "still on at the silence timeout");
    board_tick(&b, 1);
    CHECK(!b.enabled && b.drive[0] == 0 && (board_faults(&b) & FAULT_SILENCE), "off at the silence timeout");
    check_outputs(&b, "silence");
    n = proto_encode(f, MSG_STATUS, 32, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_STATUS_REPLY && (r->payload[0] & FAULT_SILENCE) && (r->payload[3] & 0x0F) == 0 &&
              (r->payload[3] & MODULE_RELAXING),
          "status after silence: off, module 1 relaxing");
    n = proto_encode(f, MSG_HEARTBEAT, 33, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.drive[0] == 0, "a heartbeat does not switch back on");
    board_tick(&b, (uint16_t)(BHR_RELAX_MS + 2 * BHR_PWM_PERIOD_MS)); /* the released wires relax */
    n = set_codes_frame(f, 34, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.drive[0] == 3 && !(board_faults(&b) & FAULT_SILENCE),
          "codes switch back on and clear the silence fault");
    n = proto_encode(f, MSG_STOP_ALL, 40, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK && !b.enabled && !board_faults(&b), "stop-all");
    check_outputs(&b, "stop");
}

/* ---------------------------------------------------------------- thermal model */

/* Keep the host alive and run ms milliseconds, one at a time; measure what
 * actuator a (0-based) shows on the pins. */
typedef struct {
    unsigned long on_ms, run, max_run, first_off; /* first_off: ms until the first off millisecond */
} pins_t;

static unsigned long clock_ms;

static void run_ms(board_t *b, unsigned long ms, int a, pins_t *p)
{
    uint8_t f[PROTO_MAX_FRAME];
    const proto_frame_t *r;
    for (unsigned long t = 0; t < ms; t++) {
        if (++clock_ms % 250 == 0) {
            uint8_t n = proto_encode(f, MSG_HEARTBEAT, 1, NULL, 0);
            send(b, f, n, &r);
        }
        int on = (b->shown[a / 4] >> (a % 4)) & 1;
        if (p) {
            if (on) {
                p->on_ms++;
                if (++p->run > p->max_run)
                    p->max_run = p->run;
            } else {
                p->run = 0;
                if (!p->first_off)
                    p->first_off = t + 1;
            }
        }
        board_tick(b, 1);
        CHECK(b->theta[a] < BHR_THETA_LIMIT + 64, "wire %d above the limit (%ld)", a, (long)b->theta[a]);
    }
}

static double tau_ms(void)
{
    double d = (double)BHR_HOLD_TICKS / BHR_PWM_PERIOD_MS;
    return BHR_CONTRACT_MS / log(1.0 / (1.0 - d));
}

static void test_thermal(void)
{
    board_t b;
    uint8_t f[PROTO_MAX_FRAME];
    const proto_frame_t *r;
    uint8_t codes[BHR_MODULES] = {0};
    uint8_t n;

    /* cold start: every wire assumed at the limit; every module cools first */
    board_init(&b);
    n = proto_encode(f, MSG_STATUS, 1, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_STATUS_REPLY && (r->payload[0] & FAULT_COOLING) &&
              (r->payload[3] & MODULE_COOLING),
          "a cold start reports cooling");
    codes[0] = 3;
    n = set_codes_frame(f, 2, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.drive[0] == 0, "codes held off while cooling after power-up");
    unsigned long t = 0;
    while ((b.module_flags[0] & MODULE_COOLING) && t < 20000) {
        run_ms(&b, 1, 0, NULL);
        t++;
    }
    double want = tau_ms() * log((double)BHR_THETA_LIMIT / BHR_THETA_RELAX);
    printf("thermal: power-up cool-down %lu ms (model %.0f ms)\n", t, want);
    CHECK(fabs((double)t - want) <= 2 * BHR_PWM_PERIOD_MS, "cool-down after power-up took %lu ms, model %.0f", t, want);
    CHECK(b.drive[0] == 3, "module 1 follows the host once cooled");
    n = proto_encode(f, MSG_STOP_ALL, 3, NULL, 0);
    send(&b, f, n, &r);

    /* contraction: from cold, full power for the contraction time */
    ready_board(&b);
    n = set_codes_frame(f, 4, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.drive[0] == 3 && b.full[0], "full power at once");
    pins_t p = {0};
    run_ms(&b, 3000, 0, &p);
    printf("thermal: contraction at full power %lu ms (datasheet figure %u ms)\n", p.first_off - 1,
           (unsigned)BHR_CONTRACT_MS);
    CHECK(p.first_off - 1 >= BHR_CONTRACT_MS && p.first_off - 1 <= BHR_CONTRACT_MS + 2 * BHR_PWM_PERIOD_MS,
          "full power lasted %lu ms", p.first_off - 1);
    CHECK(b.theta[0] >= BHR_THETA_ONE && b.theta[1] >= BHR_THETA_ONE, "contracted");

    /* hold: PWM at the hold duty, indefinitely (15 s), no fault, temperature stays at 1 */
    pins_t h = {0};
    run_ms(&b, 15000, 0, &h);
    double duty = (double)h.on_ms / 15000.0;
    printf("thermal: hold over 15 s: duty %.4f (model %u/%u), longest on %lu ms\n", duty, (unsigned)BHR_HOLD_TICKS,
           (unsigned)BHR_PWM_PERIOD_MS, h.max_run);
    CHECK(fabs(duty - (double)BHR_HOLD_TICKS / BHR_PWM_PERIOD_MS) < 0.002, "hold duty %.4f", duty);
    CHECK(h.max_run <= BHR_HOLD_TICKS, "hold pulses of %lu ms", h.max_run);
    CHECK(!board_faults(&b) && b.drive[0] == 3, "held 15 s with no fault");
    CHECK(labs((long)b.theta[0] - BHR_THETA_ONE) < BHR_THETA_ONE / 50, "held at theta = 1 (%ld)", (long)b.theta[0]);

    /* cooling: released, the wires relax in the relaxation time */
    codes[0] = 0;
    n = set_codes_frame(f, 5, codes, BHR_MODULES);
    send(&b, f, n, &r);
    CHECK(board_relaxing(&b, 0) && board_relaxing(&b, 1), "released wires are relaxing");
    t = 0;
    while (board_relaxing(&b, 0) && t < 20000) {
        run_ms(&b, 1, 0, NULL);
        t++;
    }
    printf("thermal: relaxation %lu ms (datasheet figure %u ms)\n", t, (unsigned)BHR_RELAX_MS);
    CHECK(t + 2 * BHR_PWM_PERIOD_MS >= BHR_RELAX_MS && t <= BHR_RELAX_MS + 2 * BHR_PWM_PERIOD_MS,
          "relaxed after %lu ms", t);

    /* re-energising a hot wire: held off (fault "early") until it has relaxed */
    codes[0] = 3;
    n = set_codes_frame(f, 6, codes, BHR_MODULES);
    send(&b, f, n, &r);
    run_ms(&b, 1500, 0, NULL);
    codes[0] = 6; /* wire 1 released, wire 3 energised */
    n = set_codes_frame(f, 7, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && b.drive[0] == 6, "3 -> 6");
    run_ms(&b, 200, 0, NULL);
    codes[0] = 3; /* wire 1 again, 200 ms after its release */
    n = set_codes_frame(f, 8, codes, BHR_MODULES);
    CHECK(send(&b, f, n, &r) == MSG_ACK && (r->payload[1] & FAULT_EARLY) && b.drive[0] == 0 &&
              (b.module_flags[0] & MODULE_EARLY),
          "a hot wire is not re-energised: module held off, fault early");
    /* the module is off whole, so it waits for its hottest wire to relax */
    int32_t hottest = 0;
    for (int k = 0; k < 4; k++)
        if (b.theta[k] > hottest)
            hottest = b.theta[k];
    double wait = tau_ms() * log((double)hottest / BHR_THETA_RELAX);
    pins_t e = {0};
    t = 0;
    while (b.drive[0] != 3 && t < 20000) {
        run_ms(&b, 1, 0, &e);
        t++;
    }
    printf("thermal: re-energised wire held off %lu ms (model %.0f ms: hottest wire at %.3f)\n", t, wait,
           (double)hottest / BHR_THETA_ONE);
    CHECK(e.on_ms == 0, "wire 1 was on while held");
    CHECK(fabs((double)t - wait) <= 2 * BHR_PWM_PERIOD_MS, "held %lu ms, model %.0f ms", t, wait);
    n = proto_encode(f, MSG_STOP_ALL, 9, NULL, 0);
    CHECK(send(&b, f, n, &r) == MSG_ACK && !(board_faults(&b) & FAULT_EARLY), "stop-all clears early");

    /* per wire: a wire that stays on across a code change keeps its hold (3 -> 6 keeps wire 2) */
    ready_board(&b);
    memset(codes, 0, sizeof(codes));
    codes[0] = 3;
    n = set_codes_frame(f, 11, codes, BHR_MODULES);
    send(&b, f, n, &r);
    run_ms(&b, 1500, 1, NULL);
    CHECK(b.full[0] == 0, "wires 1 and 2 contracted and holding after 1.5 s (full %x)", b.full[0]);
    unsigned long hold_on = 0, total = 0;
    for (int k = 0; k < 50; k++) { /* 3 <-> 6 every 1.2 s for 60 s */
        codes[0] = (k % 2) ? 3 : 6;
        n = set_codes_frame(f, (uint8_t)(12 + k), codes, BHR_MODULES);
        send(&b, f, n, &r);
        CHECK(!(b.full[0] & 0x02), "code change %d re-pulsed the wire that stays on (full %x)", k, b.full[0]);
        pins_t q = {0};
        run_ms(&b, 1200, 1, &q);
        hold_on += q.on_ms;
        total += 1200;
        CHECK(q.max_run <= 2 * BHR_PWM_PERIOD_MS, "wire 2 on %lu ms in a row while holding", q.max_run);
    }
    printf("thermal: 3 <-> 6 every 1.2 s for 60 s: wire 2 duty %.3f (hold %u/%u), never at full power again\n",
           (double)hold_on / total, (unsigned)BHR_HOLD_TICKS, (unsigned)BHR_PWM_PERIOD_MS);
    CHECK((double)hold_on / total <= (double)BHR_HOLD_TICKS / BHR_PWM_PERIOD_MS + 0.02, "wire 2 duty %.3f",
          (double)hold_on / total);
    n = proto_encode(f, MSG_STOP_ALL, 9, NULL, 0);
    send(&b, f, n, &r);

    /* the last line of defence: a wire at the limit switches its module off */
    ready_board(&b);
    codes[0] = 3;
    if (BHR_MODULES > 2)
        codes[2] = 6;
    n = set_codes_frame(f, 10, codes, BHR_MODULES);
    send(&b, f, n, &r);
    b.theta[0] = BHR_THETA_LIMIT - 1; /* as if the model had been defeated */
    run_ms(&b, BHR_PWM_PERIOD_MS, 0, NULL);
    CHECK(b.drive[0] == 0 && b.module_flags[0] == (MODULE_OVERHEAT | MODULE_COOLING), "overheat switches module 1 off");
    if (BHR_MODULES > 2)
        CHECK(b.drive[2] == 6, "other modules unaffected");
    CHECK(board_faults(&b) & FAULT_OVERHEAT, "overheat fault");
    check_outputs(&b, "overheat");

    /* a reset keeps the temperatures and the latched faults, switches off, and says so */
    board_t saved = b;
    CHECK(board_resume(&b) == 1 && !b.enabled && b.theta[0] == saved.theta[0] &&
              (board_faults(&b) & (FAULT_RESET | FAULT_OVERHEAT | FAULT_COOLING)) ==
                  (FAULT_RESET | FAULT_OVERHEAT | FAULT_COOLING),
          "resume after a reset");
    b.magic ^= 1u;
    CHECK(board_resume(&b) == 0 && (board_faults(&b) & FAULT_COOLING) && b.theta[5] == BHR_THETA_LIMIT,
          "a broken state is a cold start");
}

/* The attack: all-on codes every 200 ms, back-to-back heartbeats, status
 * requests and bad-CRC bursts in between, at line rate in both directions.
 * Replies go through a transmit ring drained at line rate, as on the chip. */
static void test_flood(void)
{
    board_t b;
    ready_board(&b);
    proto_parser_t p;
    proto_parser_init(&p);
    static ctx_t c;
    memset(&c, 0, sizeof(c));
    c.b = &b;
    ring_t tx;
    memset(&tx, 0, sizeof(tx));
    uint8_t all_on[BHR_MODULES];
    memset(all_on, 15, sizeof(all_on));
    uint8_t stream[4096];
    size_t have = 0, at = 0;
    unsigned long sent_replies = 0, line_in = 0, line_out = 0;
    unsigned long on_ms[BHR_ACTUATORS] = {0}, run[BHR_ACTUATORS] = {0}, max_run[BHR_ACTUATORS] = {0};
    const unsigned long total = 15000;
    uint8_t seq = 0;
    for (unsigned long t = 0; t < total; t++) {
        /* 11.52 bytes per ms each way at 115200 baud, 8N1 */
        unsigned in = (unsigned)((t + 1) * 1152 / 100 - t * 1152 / 100);
        for (unsigned k = 0; k < in; k++) {
            if (at == have) { /* next burst */
                have = at = 0;
                uint8_t fr[PROTO_MAX_FRAME];
                unsigned kind = (unsigned)((t / 200) % 3);
                if (t % 200 < 12) {
                    have = set_codes_frame(stream, seq++, all_on, BHR_MODULES);
                } else {
                    for (int i = 0; i < 40; i++) {
                        uint8_t type = kind == 0 ? MSG_HEARTBEAT : kind == 1 ? MSG_STATUS : MSG_HEARTBEAT;
                        uint8_t nn = proto_encode(fr, type, seq++, NULL, 0);
                        if (kind == 2)
                            fr[nn - 1] ^= 0x55; /* bad CRC: each one answered by a longer NAK */
                        memcpy(stream + have, fr, nn);
                        have += nn;
                    }
                }
            }
            line_in++;
            c.replies = 0;
            c.last_reply_len = 0;
            proto_parser_feed(&p, stream[at++], handler, &c);
            if (c.replies) { /* the reply goes to the transmit ring, or is dropped */
                if (ring_write(&tx, c.last_reply, c.last_reply_len))
                    sent_replies++;
                else
                    board_reply_dropped(&b);
            }
        }
        unsigned out = (unsigned)((t + 1) * 1152 / 100 - t * 1152 / 100);
        for (unsigned k = 0; k < out && !ring_empty(&tx); k++) {
            (void)ring_get(&tx);
            line_out++;
        }
        for (int a = 0; a < BHR_ACTUATORS; a++) {
            if ((b.shown[a / 4] >> (a % 4)) & 1) {
                on_ms[a]++;
                if (++run[a] > max_run[a])
                    max_run[a] = run[a];
            } else {
                run[a] = 0;
            }
        }
        board_tick(&b, 1);
        check_outputs(&b, "flood");
    }
    unsigned long worst_run = 0;
    double worst_duty = 0;
    for (int a = 0; a < BHR_ACTUATORS; a++) {
        if (max_run[a] > worst_run)
            worst_run = max_run[a];
        double d = (double)on_ms[a] / total;
        if (d > worst_duty)
            worst_duty = d;
    }
    /* over the whole attack: one contraction, then the hold duty */
    double allowed = ((double)BHR_CONTRACT_MS + 2 * BHR_PWM_PERIOD_MS +
                      (double)(total - BHR_CONTRACT_MS) * BHR_HOLD_TICKS / BHR_PWM_PERIOD_MS) / total;
    printf("flood: %lu bytes in, %lu out, %lu replies sent, %u dropped; longest on %lu ms (limit %u), "
           "duty %.3f (model allows %.3f)\n",
           line_in, line_out, sent_replies, (unsigned)b.dropped, worst_run, (unsigned)BHR_MAX_FULL_MS, worst_duty,
           allowed);
    CHECK(b.dropped > 0 && (board_faults(&b) & FAULT_FLOOD), "dropped replies are counted");
    CHECK(worst_run <= BHR_CONTRACT_MS + 2 * BHR_PWM_PERIOD_MS && worst_run < BHR_MAX_FULL_MS, "on for %lu ms",
          worst_run);
    CHECK(worst_duty <= allowed + 0.002, "duty %.3f over the attack", worst_duty);
    CHECK(!(board_faults(&b) & (FAULT_OVERHEAT | FAULT_SILENCE)), "no overheat, no silence");
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
    ready_board(&b);
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
        unsigned step = rnd_below(16) ? rnd_below(20) : rnd_below(3000); /* ticks run 1 ms at a time: keep idle gaps rarer */
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
    board_tick(&b, 20000); /* past the power-up cool-down */
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

/* `test_host trace`: the thermal drive on schedules read from stdin, for
 * bhr/thermal.py to reproduce tick for tick (tests/test_thermal.py). Each
 * schedule: "end END_MS", optionally "theta Q1 ... Q4N" (start temperatures,
 * Q14; default cold), rows "t_ms code1 ... codeN", then a line ".". Prints,
 * per schedule: the Q14 temperature of every wire at every PWM period end
 * ("t q1 ... q4N"), "early ROW MODULE" for each row (1-based) that asked a
 * module for a wire still relaxing, "overheat MODULE T" for each module's
 * first overheat, "on MS1 ... MS4N" (each wire's total on-time on the pins)
 * and ".". Heartbeats every 250 ms keep the host alive. */
static int trace(void)
{
    char line[1024];
    while (fgets(line, sizeof(line), stdin)) {
        board_t b;
        unsigned long t = 0, end = 0, at;
        if (sscanf(line, "end %lu", &end) != 1)
            return 2;
        board_init(&b);
        for (int i = 0; i < BHR_ACTUATORS; i++)
            b.theta[i] = 0; /* cold wires */
        for (int m = 0; m < BHR_MODULES; m++) {
            b.module_flags[m] = 0;
            b.cool[m] = 0;
        }
        unsigned long on_ms[BHR_ACTUATORS] = {0};
        long over_t[BHR_MODULES];
        for (int m = 0; m < BHR_MODULES; m++)
            over_t[m] = -1;
        uint8_t codes[BHR_MODULES];
        uint8_t f[PROTO_MAX_FRAME];
        const proto_frame_t *r;
        int more = fgets(line, sizeof(line), stdin) != NULL;
        if (more && strncmp(line, "theta", 5) == 0) {
            char *p = line + 5;
            int used;
            for (int i = 0; i < BHR_ACTUATORS; i++) {
                long q;
                if (sscanf(p, "%ld%n", &q, &used) != 1)
                    return 2;
                b.theta[i] = (int32_t)q;
                p += used;
            }
            /* the board's own rule for a wire whose past is hot: cooling until relaxed */
            for (int m = 0; m < BHR_MODULES; m++)
                for (int k = 0; k < 4; k++)
                    if (b.theta[m * 4 + k] > BHR_THETA_RELAX) {
                        b.cool[m] |= (uint8_t)(1u << k);
                        b.module_flags[m] |= MODULE_COOLING;
                    }
            more = fgets(line, sizeof(line), stdin) != NULL;
        }
        unsigned long row = 0;
        while (t <= end) {
            while (more && line[0] != '.') {
                char *p = line;
                int used;
                if (sscanf(p, "%lu%n", &at, &used) != 1 || at > t)
                    break;
                p += used;
                for (int m = 0; m < BHR_MODULES; m++) {
                    unsigned v;
                    if (sscanf(p, "%u%n", &v, &used) != 1)
                        return 2;
                    codes[m] = (uint8_t)v;
                    p += used;
                }
                for (int m = 0; m < BHR_MODULES; m++)
                    b.module_flags[m] &= (uint8_t)~MODULE_EARLY; /* a latch: cleared to see each row's */
                uint8_t n = set_codes_frame(f, 1, codes, BHR_MODULES);
                send(&b, f, n, &r);
                row++;
                for (int m = 0; m < BHR_MODULES; m++)
                    if (b.module_flags[m] & MODULE_EARLY)
                        printf("early %lu %d\n", row, m + 1);
                more = fgets(line, sizeof(line), stdin) != NULL;
            }
            if (t % BHR_PWM_PERIOD_MS == 0) {
                printf("%lu", t);
                for (int i = 0; i < BHR_ACTUATORS; i++)
                    printf(" %ld", (long)b.theta[i]);
                printf("\n");
            }
            if (t == end)
                break;
            if (t % 250 == 0) {
                uint8_t n = proto_encode(f, MSG_HEARTBEAT, 2, NULL, 0);
                send(&b, f, n, &r);
            }
            for (int m = 0; m < BHR_MODULES; m++)
                for (int k = 0; k < 4; k++)
                    if ((b.shown[m] >> k) & 1)
                        on_ms[m * 4 + k]++;
            board_tick(&b, 1);
            check_outputs(&b, "trace");
            t++;
            for (int m = 0; m < BHR_MODULES; m++)
                if (over_t[m] < 0 && (b.module_flags[m] & MODULE_OVERHEAT))
                    over_t[m] = (long)t;
        }
        while (more && line[0] != '.')
            more = fgets(line, sizeof(line), stdin) != NULL;
        for (int m = 0; m < BHR_MODULES; m++)
            if (over_t[m] >= 0)
                printf("overheat %d %ld\n", m + 1, over_t[m]);
        printf("on");
        for (int i = 0; i < BHR_ACTUATORS; i++)
            printf(" %lu", on_ms[i]);
        printf("\n.\n");
    }
    return 0;
}

/* `test_host crc`: the CRC of each line of hex on stdin (for tests/test_protocol.py). */
static int crc_lines(void)
{
    char line[4096];
    static uint8_t buf[2048];
    while (fgets(line, sizeof(line), stdin)) {
        uint16_t n = 0;
        unsigned v;
        int used;
        char *p = line;
        while (n < sizeof(buf) && sscanf(p, "%2x%n", &v, &used) == 1) {
            buf[n++] = (uint8_t)v;
            p += used;
        }
        printf("%04x\n", proto_crc16(PROTO_CRC_INIT, buf, n));
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "vectors") == 0)
        return vectors();
    if (argc > 1 && strcmp(argv[1], "trace") == 0)
        return trace();
    if (argc > 1 && strcmp(argv[1], "crc") == 0)
        return crc_lines();
    unsigned long count = argc > 1 ? strtoul(argv[1], NULL, 10) : 120000UL;
    if (argc > 2)
        rng_state = strtoull(argv[2], NULL, 10) | 1ULL;
    printf("host tests: BHR_MODULES=%d silence=%lu ms contraction=%u ms hold=%u/%u ms relax=%u ms full-max=%u ms "
           "seed=%llu\n",
           BHR_MODULES, (unsigned long)BHR_SILENCE_MS, (unsigned)BHR_CONTRACT_MS, (unsigned)BHR_HOLD_TICKS,
           (unsigned)BHR_PWM_PERIOD_MS, (unsigned)BHR_RELAX_MS, (unsigned)BHR_MAX_FULL_MS, rng_state);
    test_crc();
    test_codes();
    test_parser_resync();
    test_board();
    test_thermal();
    test_flood();
    fuzz(count);
    printf("OK: %lu checks passed\n", checks);
    return 0;
}
