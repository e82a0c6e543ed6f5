/*
 * main.c - bhr actuator board firmware for the ATmega328P at 16 MHz.
 *
 * UART0 receives frames (RX interrupt into a ring buffer), the portable
 * parser and state machine (proto.c, board.c) decide, and the 74HC595 chain
 * (hc595.c) drives the nitinol actuators. Replies leave through a second
 * ring buffer drained by the UART's data-register-empty interrupt, so the
 * main loop never waits for the line: a reply that does not fit is dropped
 * and counted (fault "flood"). Timer0 gives a 1 ms tick; the loop runs the
 * board's tick (PWM, thermal model) for every millisecond and resets the
 * watchdog whatever arrives. The board's state lives in .noinit RAM, so a
 * watchdog or brown-out reset keeps the wires' temperatures and the latched
 * faults (and reports "reset"); a power-up assumes hot wires and cools first.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <stdint.h>

#include "board.h"
#include "config.h"
#include "hc595.h"
#include "proto.h"
#include "ring.h"

#ifndef F_CPU
#error "F_CPU must be set (16000000UL)"
#endif

/* Bytes handled per pass of the main loop before time is looked at again. */
#define RX_BURST 16u

static ring_t rx, tx;
static volatile uint16_t ms_now;

/* Not cleared at start-up: survives a watchdog or brown-out reset. */
static board_t board __attribute__((section(".noinit")));
static uint8_t reset_cause __attribute__((section(".noinit")));
static proto_parser_t parser;

/* Save the reset cause, then clear it and switch the watchdog off until main()
 * sets it: after a watchdog reset it stays armed with the shortest period. */
void early_wdt_off(void) __attribute__((naked, used, section(".init3")));
void early_wdt_off(void)
{
    reset_cause = MCUSR;
    MCUSR = 0;
    wdt_disable();
}

ISR(USART_RX_vect)
{
    uint8_t status = UCSR0A;
    uint8_t c = UDR0;
    if (status & (1u << FE0)) /* framing error: the byte is noise */
        return;
    (void)ring_put(&rx, c); /* on overflow the byte is lost; the CRC catches it */
}

ISR(USART_UDRE_vect)
{
    if (ring_empty(&tx))
        UCSR0B &= (uint8_t)~(1u << UDRIE0); /* nothing left: stop asking */
    else
        UDR0 = ring_get(&tx);
}

ISR(TIMER0_COMPA_vect)
{
    ms_now++;
}

static uint16_t millis(void)
{
    uint16_t t;
    uint8_t s = SREG;
    cli();
    t = ms_now;
    SREG = s;
    return t;
}

static void uart_init(void)
{
    UCSR0A = (uint8_t)(1u << U2X0);
    uint16_t ubrr = (uint16_t)((F_CPU + 4UL * BHR_BAUD) / (8UL * BHR_BAUD) - 1UL);
    UBRR0H = (uint8_t)(ubrr >> 8);
    UBRR0L = (uint8_t)ubrr;
    UCSR0C = (uint8_t)((1u << UCSZ01) | (1u << UCSZ00)); /* 8N1 */
    UCSR0B = (uint8_t)((1u << RXEN0) | (1u << TXEN0) | (1u << RXCIE0));
}

/* Queue a reply; never waits. A reply that does not fit whole is dropped
 * (the host retries) and counted. */
static void uart_send(const uint8_t *p, uint8_t n)
{
    if (!ring_write(&tx, p, n)) {
        board_reply_dropped(&board);
        return;
    }
    UCSR0B |= (uint8_t)(1u << UDRIE0);
}

static void timer_init(void)
{
    TCCR0A = (uint8_t)(1u << WGM01);               /* CTC */
    OCR0A = (uint8_t)(F_CPU / 64UL / 1000UL - 1UL); /* 249 at 16 MHz */
    TCCR0B = (uint8_t)((1u << CS01) | (1u << CS00)); /* /64 */
    TIMSK0 = (uint8_t)(1u << OCIE0A);
}

static void push_outputs(void);

static void on_event(void *ctx, uint8_t event, const proto_frame_t *f)
{
    (void)ctx;
    uint8_t reply[PROTO_MAX_FRAME];
    uint8_t n = board_handle(&board, event, f, reply);
    if (board.changed) /* the outputs show the new codes before the ACK leaves */
        push_outputs();
    if (n)
        uart_send(reply, n);
}

static void push_outputs(void)
{
    uint8_t chain[BHR_CHIPS];
    board_chain(&board, chain);
    if (!board.enabled) {
        hc595_disable(); /* everything off at once, then clear the chain */
        hc595_write(chain);
    } else {
        hc595_write(chain);
        hc595_enable();
    }
    board.changed = 0;
}

int main(void)
{
    hc595_init();
    /* a power-on reset (or garbage in RAM) is a cold start: every wire is assumed hot */
    if (reset_cause & (1u << PORF))
        board_init(&board);
    else
        (void)board_resume(&board);
    proto_parser_init(&parser);
    uart_init();
    timer_init();
    set_sleep_mode(SLEEP_MODE_IDLE);
    wdt_enable(WDTO_250MS);
    sei();

    uint16_t last_tick = millis();
    uint16_t last_rx = last_tick;
    for (;;) {
        wdt_reset();
        /* Time first: ticks that elapsed before the bytes below arrived must
         * not count against the frame they complete. */
        uint16_t now = millis();
        uint16_t dt = (uint16_t)(now - last_tick);
        if (dt) {
            last_tick = now;
            board_tick(&board, dt);
            if (board.changed) /* PWM edges on time */
                push_outputs();
        }
        for (uint8_t k = 0; k < RX_BURST && !ring_empty(&rx); k++) {
            uint8_t c = ring_get(&rx);
            last_rx = millis();
            proto_parser_feed(&parser, c, on_event, 0);
            if (board.changed)
                push_outputs();
        }
        /* read the clock again: last_rx may be newer than `now` */
        if (proto_parser_pending(&parser) && (uint16_t)(millis() - last_rx) >= BHR_FRAME_GAP_MS)
            proto_parser_expire(&parser, on_event, 0);
        if (board.changed)
            push_outputs();
        /* Reading UCSR0A also tells simavr's UART that we are ready for
         * more input; on the chip it is harmless. */
        (void)UCSR0A;
        cli();
        if (ring_empty(&rx) && millis() == last_tick) {
            sleep_enable();
            sei();
            sleep_cpu(); /* the next tick or byte wakes us */
            sleep_disable();
        }
        sei();
    }
}
