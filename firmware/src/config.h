/*
 * config.h - compile-time settings of the bhr actuator board.
 *
 * Every value can be overridden on the compiler's command line
 * (make MODULES=16 ...; the sim build passes short timing limits, see Makefile).
 * docs/firmware.md explains each one.
 */
#ifndef BHR_CONFIG_H
#define BHR_CONFIG_H

/* Number of modules driven by the board (4 actuators each, two modules per
 * 74HC595). Frames must carry exactly this many codes. 5 = the thesis head
 * that `bhr follow` simulates by default. */
#ifndef BHR_MODULES
#define BHR_MODULES 5
#endif

/* Silence timeout: no accepted frame (codes, status, stop or heartbeat) for
 * this long while outputs are on -> everything off (fault "silence"). */
#ifndef BHR_SILENCE_MS
#define BHR_SILENCE_MS 1000UL
#endif

/* The thermal model of the actuator wires (contraction, PWM hold, relaxation,
 * overheat limit) comes from the generated header bhr_gen.h, made from the
 * robot file's [thermal] table by `python -m bhr._hardware.firmware_header`. */

/* A partial frame with no further byte for this long is dropped (NAK
 * "incomplete" when its header was complete). */
#ifndef BHR_FRAME_GAP_MS
#define BHR_FRAME_GAP_MS 50U
#endif

/* UART speed (8N1). */
#ifndef BHR_BAUD
#define BHR_BAUD 115200UL
#endif

#define BHR_CHIPS ((BHR_MODULES + 1) / 2)
#define BHR_ACTUATORS (BHR_MODULES * 4)

#if BHR_MODULES < 1 || BHR_MODULES > 32
#error "BHR_MODULES must be 1..32"
#endif
#if BHR_SILENCE_MS < 10 || BHR_SILENCE_MS > 60000UL
#error "BHR_SILENCE_MS must be 10..60000"
#endif

#endif
