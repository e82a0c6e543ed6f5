/* board.c - board state machine and thermal drive (see board.h, docs/firmware.md, docs/thermal.md).
 *
 * Keep in step with bhr/thermal.py (_kernel_py): the host plans streams with
 * the same integer model, and tests hold the two equal. */
#include "board.h"

#include <string.h>

/* The model's products fit in 32 bits (no 64-bit arithmetic on the AVR). */
#if BHR_THETA_FULL * BHR_THETA_A_Q16 >= 0x40000000L
#error "thermal constants too large for 32-bit arithmetic"
#endif

/* Equilibrium temperature for each number of on-milliseconds in a period:
 * (on * BHR_THETA_FULL) / BHR_PWM_PERIOD_MS, computed once (a division costs
 * hundreds of cycles on the AVR). */
static int32_t target_tab[BHR_PWM_PERIOD_MS + 1];

static void fill_targets(void)
{
    for (uint8_t k = 0; k <= BHR_PWM_PERIOD_MS; k++)
        target_tab[k] = (int32_t)(((int32_t)k * BHR_THETA_FULL) / (int32_t)BHR_PWM_PERIOD_MS);
}

void board_init(board_t *b)
{
    fill_targets();
    memset(b, 0, sizeof(*b));
    for (uint8_t i = 0; i < BHR_ACTUATORS; i++)
        b->theta[i] = BHR_THETA_LIMIT; /* unknown past: assume hot wires */
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        b->module_flags[m] = MODULE_COOLING;
        b->cool[m] = 0x0F;
    }
    b->magic = BOARD_MAGIC;
    b->magic_inv = (uint32_t)~(uint32_t)BOARD_MAGIC;
    b->changed = 1; /* push the all-off state once */
}

uint8_t board_resume(board_t *b)
{
    fill_targets();
    uint8_t ok = b->magic == BOARD_MAGIC && b->magic_inv == (uint32_t)~(uint32_t)BOARD_MAGIC;
    for (uint8_t i = 0; ok && i < BHR_ACTUATORS; i++)
        if (b->theta[i] < 0 || b->theta[i] > 4L * BHR_THETA_FULL)
            ok = 0;
    for (uint8_t m = 0; ok && m < BHR_MODULES; m++)
        if (b->cool[m] > 0x0F || !(b->module_flags[m] & MODULE_COOLING) != !b->cool[m])
            ok = 0;
    if (!ok) {
        board_init(b);
        return 0;
    }
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        b->requested[m] = 0;
        b->drive[m] = 0;
        b->full[m] = 0;
        b->shown[m] = 0;
        b->module_flags[m] &= (uint8_t)(MODULE_OVERHEAT | MODULE_COOLING | MODULE_EARLY);
    }
    memset(b->on_ticks, 0, sizeof(b->on_ticks));
    b->phase = 0;
    b->enabled = 0;
    b->quiet_ms = 0;
    b->faults = (uint8_t)((b->faults & (FAULT_SILENCE | FAULT_FLOOD)) | FAULT_RESET);
    b->changed = 1;
    return 1;
}

uint8_t board_faults(const board_t *b)
{
    uint8_t f = b->faults;
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        if (b->module_flags[m] & MODULE_OVERHEAT)
            f |= FAULT_OVERHEAT;
        if (b->module_flags[m] & MODULE_COOLING)
            f |= FAULT_COOLING;
        if (b->module_flags[m] & MODULE_EARLY)
            f |= FAULT_EARLY;
    }
    return f;
}

void board_reply_dropped(board_t *b)
{
    if (b->dropped < 0xFFFFu)
        b->dropped++;
    b->faults |= FAULT_FLOOD;
}

uint8_t board_relaxing(const board_t *b, uint8_t a)
{
    return !((b->drive[a / 4u] >> (a % 4u)) & 1u) && b->theta[a] > BHR_THETA_RELAX;
}

/* 1 when driving `want` on module m would energise a wire that is still relaxing */
static uint8_t blocked(const board_t *b, uint8_t m, uint8_t want)
{
    uint8_t new_on = (uint8_t)(want & ~b->drive[m]);
    for (uint8_t k = 0; k < 4; k++)
        if (((new_on >> k) & 1u) && b->theta[m * 4u + k] > BHR_THETA_RELAX)
            return 1;
    return 0;
}

/* The wires of `code` on module m that are below theta = 1 (they need full power). */
static uint8_t cold_wires(const board_t *b, uint8_t m, uint8_t code)
{
    uint8_t mask = 0;
    for (uint8_t k = 0; k < 4; k++)
        if (((code >> k) & 1u) && b->theta[m * 4u + k] < BHR_THETA_ONE)
            mask |= (uint8_t)(1u << k);
    return mask;
}

/* What module m shows this millisecond: of the wires it drives, those at full
 * power all period, those holding in the first BHR_HOLD_TICKS ms of it. */
static void show(board_t *b)
{
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t s = b->drive[m];
        if (!b->enabled)
            s = 0;
        else if (b->phase >= BHR_HOLD_TICKS)
            s &= b->full[m];
        if (!proto_code_valid(b->drive[m])) /* cannot happen: drive[] holds validated codes */
            s = 0;
        if (s != b->shown[m]) {
            b->shown[m] = s;
            b->changed = 1;
        }
    }
}

/* Module m drives `want` from now on: the wires it energises anew start at
 * full power if they are below theta = 1; a wire that stays on keeps its
 * drive (a holding wire is not pulsed again). */
static void set_drive(board_t *b, uint8_t m, uint8_t want)
{
    uint8_t new_on = (uint8_t)(want & ~b->drive[m]);
    b->full[m] = (uint8_t)((b->full[m] & want) | cold_wires(b, m, new_on));
    b->drive[m] = want;
}

/* What module m may drive of the code the host asks for: nothing while a
 * wire of that code is cooling. */
static uint8_t wanted(const board_t *b, uint8_t m)
{
    uint8_t want = b->enabled ? b->requested[m] : 0;
    return (want & b->cool[m]) ? 0 : want;
}

/* A frame changed requested[] or enabled: drive what can be driven now. */
static void apply(board_t *b, uint8_t from_frame)
{
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t want = wanted(b, m);
        if (blocked(b, m, want)) {
            if (from_frame)
                b->module_flags[m] |= MODULE_EARLY;
            want = 0;
        }
        if (want != b->drive[m])
            set_drive(b, m, want);
    }
    show(b);
}

void board_chain(const board_t *b, uint8_t chain[BHR_CHIPS])
{
    memset(chain, 0, BHR_CHIPS);
    if (!b->enabled)
        return;
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        uint8_t code = proto_code_valid(b->shown[m]) ? b->shown[m] : 0;
        chain[m / 2] |= (uint8_t)(code << ((m & 1u) * 4u));
    }
}

static void all_off(board_t *b)
{
    memset(b->requested, 0, sizeof(b->requested));
    if (b->enabled)
        b->changed = 1;
    b->enabled = 0;
    apply(b, 0);
}

/* End of a PWM period: the thermal model, the limits, the drive mode. */
static void period_end(board_t *b)
{
    for (uint8_t i = 0; i < BHR_ACTUATORS; i++) {
        uint8_t on = b->on_ticks[i] <= BHR_PWM_PERIOD_MS ? b->on_ticks[i] : BHR_PWM_PERIOD_MS;
        int32_t d = target_tab[on] - b->theta[i];
        /* arithmetic shift (floor), as in bhr/thermal.py */
        b->theta[i] += (d * BHR_THETA_A_Q16) >> 16;
        if (b->theta[i] < 0)
            b->theta[i] = 0;
        b->on_ticks[i] = 0;
    }
    for (uint8_t m = 0; m < BHR_MODULES; m++) {
        for (uint8_t k = 0; k < 4; k++) {
            int32_t t = b->theta[m * 4u + k];
            uint8_t bit = (uint8_t)(1u << k);
            if (t >= BHR_THETA_LIMIT) {
                b->cool[m] |= bit;
                b->module_flags[m] |= MODULE_OVERHEAT;
            } else if ((b->cool[m] & bit) && t <= BHR_THETA_RELAX) {
                b->cool[m] &= (uint8_t)~bit;
            }
        }
        if (b->cool[m])
            b->module_flags[m] |= MODULE_COOLING;
        else
            b->module_flags[m] &= (uint8_t)~MODULE_COOLING;
        uint8_t want = wanted(b, m);
        if (blocked(b, m, want))
            want = 0;
        set_drive(b, m, want);
        /* each wire on: full power until it has contracted, then hold */
        b->full[m] = cold_wires(b, m, b->drive[m]);
    }
}

static void tick1(board_t *b)
{
    /* silence timeout */
    if (b->quiet_ms < 0xFFFFu)
        b->quiet_ms++;
    if (b->enabled && b->quiet_ms > BHR_SILENCE_MS) { /* never early: in the tick after the timeout */
        b->faults |= FAULT_SILENCE;
        all_off(b);
    }
    /* the millisecond that just passed, with the outputs it showed */
    for (uint8_t m = 0; m < BHR_MODULES; m++)
        for (uint8_t k = 0; k < 4; k++)
            if ((b->shown[m] >> k) & 1u)
                b->on_ticks[m * 4u + k]++;
    if (++b->phase >= BHR_PWM_PERIOD_MS) {
        b->phase = 0;
        period_end(b);
    }
    show(b);
}

void board_tick(board_t *b, uint16_t dt)
{
    while (dt--)
        tick1(b);
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
        apply(b, 1);
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
        for (uint8_t m = 0; m < BHR_MODULES; m++) {
            uint8_t v = (uint8_t)((b->enabled ? b->drive[m] : 0) | b->module_flags[m]);
            for (uint8_t k = 0; k < 4; k++)
                if (board_relaxing(b, (uint8_t)(m * 4u + k)))
                    v |= MODULE_RELAXING;
            p[3 + m] = v;
        }
        return proto_encode(reply, MSG_STATUS_REPLY, f->seq, p, (uint8_t)(3 + BHR_MODULES));
    }
    case MSG_STOP_ALL:
        if (f->len != 0)
            return nak(reply, f->seq, f->type, NAK_BAD_LENGTH, 0);
        all_off(b);
        b->faults = 0;
        b->dropped = 0;
        for (uint8_t m = 0; m < BHR_MODULES; m++) /* acknowledged; cooling stays */
            b->module_flags[m] &= (uint8_t)~(MODULE_OVERHEAT | MODULE_EARLY);
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
