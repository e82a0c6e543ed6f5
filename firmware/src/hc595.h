/*
 * hc595.h - daisy-chained 74HC595 shift registers on the ATmega328P's SPI.
 *
 *   PB3 / D11 (MOSI) -> SER of chip 1; QH' of chip k -> SER of chip k+1
 *   PB5 / D13 (SCK)  -> SRCLK of every chip
 *   PB2 / D10        -> RCLK (latch) of every chip
 *   PB1 / D9         -> /OE of every chip, with a 10 k pull-up to 5 V so the
 *                       outputs stay off while the MCU is in reset
 *   /SRCLR tied to 5 V.
 */
#ifndef BHR_HC595_H
#define BHR_HC595_H

#include <stdint.h>

#include "config.h"

void hc595_init(void);                         /* /OE high, chain cleared and latched */
void hc595_disable(void);                      /* /OE high: every output off at once */
void hc595_enable(void);                       /* /OE low */
void hc595_write(const uint8_t chain[BHR_CHIPS]); /* shift (chip 1 last) and latch */

#endif
