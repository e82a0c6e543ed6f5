/*
 * board.h - the actuator board's state machine, in portable C99.
 *
 * It owns what reaches the outputs: only stable codes, never a module whose
 * actuators are too hot, nothing at all after the host falls silent or asks
 * to stop. The AVR main loop (main.c) and the host tests (test/) drive it
 * the same way: feed frames with board_handle(), advance time with
 * board_tick(), and copy board_chain() to the shift registers whenever
 * board.changed is set.
 */
#ifndef BHR_BOARD_H
#define BHR_BOARD_H

#include <stdint.h>

#include "config.h"
#include "proto.h"

typedef struct {
    uint8_t requested[BHR_MODULES]; /* last accepted codes (0 after stop/silence) */
    uint8_t output[BHR_MODULES];    /* codes on the outputs (always stable codes) */
    uint8_t module_flags[BHR_MODULES]; /* MODULE_OVERHEAT | MODULE_COOLING */
    uint32_t heat[BHR_ACTUATORS];   /* thermal accumulator per actuator */
    uint8_t faults;                 /* FAULT_SILENCE (the other bits are derived) */
    uint8_t enabled;                /* 1: output-enable active (codes accepted since last stop) */
    uint16_t quiet_ms;              /* time since the last accepted frame */
    uint8_t changed;                /* outputs differ from what the hardware shows */
} board_t;

void board_init(board_t *b);

/* Handle one parser event; write the reply frame to reply (room for
 * PROTO_MAX_FRAME bytes) and return its length (0: no reply). */
uint8_t board_handle(board_t *b, uint8_t event, const proto_frame_t *f, uint8_t *reply);

/* Advance time by dt milliseconds: silence timeout and the thermal limits. */
void board_tick(board_t *b, uint16_t dt);

/* Current fault byte (FAULT_* bits). */
uint8_t board_faults(const board_t *b);

/* The bytes for the shift-register chain, chip 1 (nearest the MCU: modules
 * 1 and 2) first; module 2k-1 in the low nibble of chip k, module 2k in the
 * high nibble, bit a-1 = actuator a. All zero while outputs are disabled. */
void board_chain(const board_t *b, uint8_t chain[BHR_CHIPS]);

#endif
