/*
 * ring.h - byte ring buffers for the UART, portable C99 (the host tests use
 * them too). One producer and one consumer; on the AVR the interrupt side
 * owns one index, the main loop the other, and every index is one byte, so
 * no access needs a lock. RING_SIZE must be a power of two, at most 256.
 */
#ifndef BHR_RING_H
#define BHR_RING_H

#include <stdint.h>

#define RING_SIZE 128u

typedef struct {
    volatile uint8_t buf[RING_SIZE];
    volatile uint8_t head; /* next byte written */
    volatile uint8_t tail; /* next byte read */
} ring_t;

static inline uint8_t ring_used(const ring_t *r)
{
    return (uint8_t)((r->head - r->tail) & (RING_SIZE - 1u));
}

static inline uint8_t ring_free(const ring_t *r)
{
    return (uint8_t)(RING_SIZE - 1u - ring_used(r));
}

static inline uint8_t ring_empty(const ring_t *r)
{
    return r->head == r->tail;
}

/* One byte in; 0 when full (the byte is lost). */
static inline uint8_t ring_put(ring_t *r, uint8_t c)
{
    uint8_t next = (uint8_t)((r->head + 1u) & (RING_SIZE - 1u));
    if (next == r->tail)
        return 0;
    r->buf[r->head] = c;
    r->head = next;
    return 1;
}

/* n bytes in, all or none; 0 when they do not fit. */
static inline uint8_t ring_write(ring_t *r, const uint8_t *p, uint8_t n)
{
    if (n > ring_free(r))
        return 0;
    for (uint8_t i = 0; i < n; i++)
        ring_put(r, p[i]);
    return 1;
}

/* One byte out (call only when not empty). */
static inline uint8_t ring_get(ring_t *r)
{
    uint8_t c = r->buf[r->tail];
    r->tail = (uint8_t)((r->tail + 1u) & (RING_SIZE - 1u));
    return c;
}

#endif
