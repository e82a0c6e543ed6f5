/* board.c - board state machine (see board.h and docs/firmware.md). */
#include "board.h"

#include <string.h>

/* Thermal model, per actuator, in units of ms x ms: while on, heat rises by
 * BHR_COOLDOWN_MS per ms; while off, it falls by BHR_ON_MAX_MS per ms. It
 * reaches HEAT_LIMIT after BHR_ON_MAX_MS ms of continuous on-time, and a
 * full HEAT_LIMIT drains in BHR_COOLDOWN_MS ms. */
#define HEAT_LIMIT ((uint32_t)BHR_ON_MAX_MS * (uint32_t)BHR_COOLDOWN_MS)

void board_init(board_t *b)
{
    memset(b, 0, sizeof(*b));
    b->changed = 1; /* push the all-off state once */
}

uint8_t board_faults(const board_t *b)
{
    uint8_t f = b->faults;
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        if (b->module_flags[m] & MODULE_OVERHEAT)
            f |= FAULT_OVERHEAT;
        if (b->module_flags[m] & MODULE_COOLING)
            f |= FAULT_COOLING;
    }
    return f;
}

/* Recompute output[] from requested[], enabled and the cooling locks. */
static void apply(board_t *b)
{
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t want = b->enabled ? b->requested[m] : 0;
        if (b->module_flags[m] & MODULE_COOLING)
            want = 0;
        if (!proto_code_valid(want)) /* cannot happen: requested[] is validated */
            want = 0;
        if (b->output[m] != want) {
            b->output[m] = want;
            b->changed = 1;
        }
    }
}

void board_chain(const board_t *b, uint8_t chain[BHR_CHIPS])
{
    memset(chain, 0, BHR_CHIPS);
    if (!b->enabled)
        return;
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t code = proto_code_valid(b->output[m]) ? b->output[m] : 0;
        chain[m / 2] |= (uint8_t)(code << ((m & 1u) * 4u));
    }
}

static void all_off(board_t *b)
{
    memset(b->requested, 0, sizeof(b->requested));
    if (b->enabled)
        b->changed = 1;
    b->enabled = 0;
    apply(b);
}

void board_tick(board_t *b, uint16_t dt)
{
    if (dt == 0)
        return;
    /* silence timeout */
    if (b->quiet_ms < 0xFFFFu - dt)
        b->quiet_ms = (uint16_t)(b->quiet_ms + dt);
    else
        b->quiet_ms = 0xFFFFu;
    if (b->enabled && b->quiet_ms > BHR_SILENCE_MS) { /* never early: in the tick after the timeout */
        b->faults |= FAULT_SILENCE;
        all_off(b);
    }
    /* thermal limits */
    uint32_t up = (uint32_t)dt * BHR_COOLDOWN_MS;
    uint32_t down = (uint32_t)dt * BHR_ON_MAX_MS;
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t code = b->output[m];
        uint8_t tripped = 0, hot = 0;
        for (uint8_t a = 0; a < 4; a++) {
            uint32_t *h = &b->heat[m * 4u + a];
            if (code & (1u << a)) {
                *h = (HEAT_LIMIT - *h <= up) ? HEAT_LIMIT : *h + up;
                if (*h >= HEAT_LIMIT)
                    tripped = 1;
            } else {
                *h = (*h <= down) ? 0 : *h - down;
            }
            if (*h)
                hot = 1;
        }
        if (tripped)
            b->module_flags[m] |= MODULE_OVERHEAT | MODULE_COOLING;
        else if ((b->module_flags[m] & MODULE_COOLING) && !hot)
            b->module_flags[m] &= (uint8_t)~MODULE_COOLING;
    }
    apply(b);
}

static uint8_t nak(uint8_t *reply, uint8_t seq, uint8_t type, uint8_t reason, uint8_t detail)
{
    uint8_t p[3] = {type, reason, detail};
    return proto_encode(reply, MSG_NAK, seq, p, 3);
}

static uint8_t ack(board_t *b, uint8_t *reply, uint8_t seq, uint8_t type)
{
    uint8_t p[2] = {type, board_faults(b)};
    return proto_encode(reply, MSG_ACK, seq, p, 2);
}

uint8_t board_handle(board_t *b, uint8_t event, const proto_frame_t *f, uint8_t *reply)
{
    if (event == PROTO_EV_BAD_CRC)
        return nak(reply, f->seq, f->type, NAK_BAD_CRC, 0);
    if (event == PROTO_EV_INCOMPLETE)
        return nak(reply, f->seq, f->type, NAK_INCOMPLETE, 0);
    if (event != PROTO_EV_FRAME)
        return 0;
    if (f->version != PROTO_VERSION)
        return nak(reply, f->seq, f->type, NAK_BAD_VERSION, PROTO_VERSION);
    switch (f->type) {
    case MSG_SET_CODES: {
        if (f->len < 1 || f->len != (uint8_t)(1u + f->payload[0]))
            return nak(reply, f->seq, f->type, NAK_BAD_LENGTH, 0);
        if (f->payload[0] != BHR_MODULES)
            return nak(reply, f->seq, f->type, NAK_BAD_COUNT, BHR_MODULES);
        for (uint8_t m = 0; m < BHR_MODULES; m++)
            if (!proto_code_valid(f->payload[1 + m]))
                return nak(reply, f->seq, f->type, NAK_BAD_CODE, (uint8_t)(m + 1));
        /* every code checked: accept the whole frame */
        memcpy(b->requested, f->payload + 1, BHR_MODULES);
        if (!b->enabled)
            b->changed = 1;
        b->enabled = 1;
        b->faults &= (uint8_t)~FAULT_SILENCE;
        b->quiet_ms = 0;
        apply(b);
        return ack(b, reply, f->seq, f->type);
    }
    case MSG_STATUS: {
        if (f->len != 0)
            return nak(reply, f->seq, f->type, NAK_BAD_LENGTH, 0);
        b->quiet_ms = 0;
        uint8_t p[3 + BHR_MODULES];
        p[0] = board_faults(b);
        p[1] = b->enabled;
        p[2] = BHR_MODULES;
        for (uint8_t m = 0; m < BHR_MODULES; m++)
            p[3 + m] = (uint8_t)((b->enabled ? b->output[m] : 0) | b->module_flags[m]);
        return proto_encode(reply, MSG_STATUS_REPLY, f->seq, p, (uint8_t)(3 + BHR_MODULES));
    }
    case MSG_STOP_ALL:
        if (f->len != 0)
            return nak(reply, f->seq, f->type, NAK_BAD_LENGTH, 0);
        all_off(b);
        b->faults = 0;
        for (uint8_t m = 0; m < BHR_MODULES; m++)
            b->module_flags[m] &= (uint8_t)~MODULE_OVERHEAT; /* acknowledged; cooling stays */
        b->quiet_ms = 0;
        return ack(b, reply, f->seq, f->type);
    case MSG_HEARTBEAT:
        if (f->len != 0)
            return nak(reply, f->seq, f->type, NAK_BAD_LENGTH, 0);
        b->quiet_ms = 0;
        return ack(b, reply, f->seq, f->type);
    default:
        return nak(reply, f->seq, f->type, NAK_BAD_TYPE, 0);
    }
}
