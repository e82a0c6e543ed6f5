/*
 * board.h - the actuator board's state machine, in portable C99.
 *
 * It owns what reaches the outputs: only the wires of a stable code, each
 * wire driven by the thermal model of its nitinol (full power until it has
 * contracted, then PWM hold; a wire that stays on across a code change keeps
 * its hold), a released wire never energised again before it has relaxed, a
 * wire that reaches the model's limit cooling (its module off while the code
 * needs it) until it has relaxed, and nothing at all after the host falls
 * silent or asks to stop. The AVR main loop (main.c) and the host tests (test/) drive it the
 * same way: feed frames with board_handle(), advance time with board_tick(),
 * and copy board_chain() to the shift registers whenever board.changed is
 * set. bhr/thermal.py runs the same drive on the host (docs/thermal.md).
 */
#ifndef BHR_BOARD_H
#define BHR_BOARD_H

#include <stdint.h>

#include "config.h"
#include "proto.h"

#define BOARD_MAGIC 0xB4C3A5E1UL

typedef struct {
    uint32_t magic;                    /* BOARD_MAGIC and its complement: the state survived a reset */
    uint8_t requested[BHR_MODULES];    /* last accepted codes (0 after stop/silence) */
    uint8_t drive[BHR_MODULES];        /* codes being driven (always stable codes) */
    uint8_t full[BHR_MODULES];         /* per wire (bit k = wire k+1): 1 full power (contracting), 0 PWM hold */
    uint8_t cool[BHR_MODULES];         /* per wire: 1 cooling after reaching the limit (off until relaxed) */
    uint8_t shown[BHR_MODULES];        /* the wires on this millisecond (a subset of drive[]) */
    uint8_t module_flags[BHR_MODULES]; /* MODULE_OVERHEAT | MODULE_EARLY latched; MODULE_COOLING = cool[] != 0 */
    int32_t theta[BHR_ACTUATORS];      /* normalised wire temperature, Q14 (BHR_THETA_ONE = contracted) */
    uint8_t on_ticks[BHR_ACTUATORS];   /* ms on in the current PWM period */
    uint8_t phase;                     /* ms into the PWM period */
    uint8_t faults;                    /* FAULT_SILENCE | FAULT_RESET | FAULT_FLOOD (the rest is derived) */
    uint8_t enabled;                   /* 1: output-enable active (codes accepted since last stop) */
    uint16_t quiet_ms;                 /* time since the last accepted frame */
    uint16_t dropped;                  /* replies dropped for want of transmit room (saturating) */
    uint8_t changed;                   /* outputs differ from what the hardware shows */
    uint32_t magic_inv;
} board_t;

/* Cold start: every wire assumed hot (at the model's limit), so every module
 * cools down first. */
void board_init(board_t *b);

/* After a reset with the RAM kept (.noinit): when the state is intact,
 * keep the wires' temperatures and latched faults, switch the outputs off,
 * flag FAULT_RESET and return 1; otherwise cold-start and return 0. */
uint8_t board_resume(board_t *b);

/* Handle one parser event; write the reply frame to reply (room for
 * PROTO_MAX_FRAME bytes) and return its length (0: no reply). */
uint8_t board_handle(board_t *b, uint8_t event, const proto_frame_t *f, uint8_t *reply);

/* Advance time by dt milliseconds, one millisecond at a time: silence
 * timeout, PWM, thermal model, limits. */
void board_tick(board_t *b, uint16_t dt);

/* A reply could not be sent (transmit buffer full): count it, flag FAULT_FLOOD. */
void board_reply_dropped(board_t *b);

/* Current fault byte (FAULT_* bits). */
uint8_t board_faults(const board_t *b);

/* 1 when actuator a (0-based, module*4 + bit) was released and has not relaxed. */
uint8_t board_relaxing(const board_t *b, uint8_t a);

/* The bytes for the shift-register chain, chip 1 (nearest the MCU: modules
 * 1 and 2) first; module 2k-1 in the low nibble of chip k, module 2k in the
 * high nibble, bit a-1 = actuator a. All zero while outputs are disabled.
 * Each module's nibble is a subset of the stable code it drives: a wire in
 * its PWM off-time is off while a wire of the same code still contracting
 * is on. */
void board_chain(const board_t *b, uint8_t chain[BHR_CHIPS]);

#endif
