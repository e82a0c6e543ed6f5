/* hc595.c - 74HC595 chain driver for the ATmega328P (see hc595.h). */
#include "hc595.h"

#include <avr/io.h>

#define OE_BIT PB1
#define LATCH_BIT PB2

void hc595_disable(void)
{
    PORTB |= (uint8_t)(1u << OE_BIT);
}

void hc595_enable(void)
{
    PORTB &= (uint8_t)~(1u << OE_BIT);
}

static void spi_byte(uint8_t v)
{
    SPDR = v;
    while (!(SPSR & (1u << SPIF)))
        ;
    (void)SPDR;
}

void hc595_write(const uint8_t chain[BHR_CHIPS])
{
    /* the first byte shifted ends in the chip farthest from the MCU */
    for (int8_t k = BHR_CHIPS - 1; k >= 0; k--)
        spi_byte(chain[k]);
    PORTB |= (uint8_t)(1u << LATCH_BIT); /* rising edge copies shift -> storage */
    PORTB &= (uint8_t)~(1u << LATCH_BIT);
}

void hc595_init(void)
{
    /* /OE high before the pin becomes an output: never a glitch on */
    PORTB |= (uint8_t)(1u << OE_BIT);
    PORTB &= (uint8_t)~(1u << LATCH_BIT);
    DDRB |= (uint8_t)((1u << OE_BIT) | (1u << LATCH_BIT) | (1u << PB3) | (1u << PB5));
    /* SPI master, MSB first, mode 0, f/2 = 8 MHz */
    SPCR = (uint8_t)((1u << SPE) | (1u << MSTR));
    SPSR = (uint8_t)(1u << SPI2X);
    uint8_t zero[BHR_CHIPS] = {0};
    hc595_write(zero);
}
