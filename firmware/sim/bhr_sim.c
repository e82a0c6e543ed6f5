/*
 * bhr_sim.c - run the bhr actuator-board firmware in simavr.
 *
 *   bhr-sim [-m MODULES] [-l LOGFILE] [-q] FIRMWARE.elf
 *
 * Loads the ELF into a simulated ATmega328P at 16 MHz, bridges UART0 to a
 * pseudo-terminal with libsimavrparts' uart_pty and watches the 74HC595
 * chain that the firmware drives over SPI (PB3 data, PB5 clock, PB2 latch,
 * PB1 /OE). The first line on standard output is "PTY <path>" (flushed);
 * then the pin log follows, one line per latch or /OE change, with the
 * simulated time (docs/firmware.md "Pin log"):
 *
 *   t_us=123456 ev=latch oe=on latched=3,0,6,0,0 codes=3,0,6,0,0
 *
 * The pin log goes to standard output, or to LOGFILE with -l (or the
 * BHR_SIM_LOG environment variable; -l wins; "-l -" is standard output).
 * `make sim` writes it to build/sim/pins.log unless SIM_LOG=- asks for the
 * terminal. Everything simavr itself
 * prints goes to standard error. SIGTERM or SIGINT stops the simulation
 * cleanly (last log line "ev=exit", exit status 0).
 *
 * The chain is modelled here (a real daisy chain of CHIPS 8-bit registers,
 * storage clocked on the latch's rising edge, outputs gated by /OE). The
 * libsimavrparts hc595 part is attached to the same SPI and latch lines as
 * a cross-check of the four chips nearest the MCU: it is 32 bits wide and
 * its chain output passes the wrong byte, so it cannot model a longer chain
 * itself. A mismatch, or a set output past the last module, is logged as an
 * "ALERT" line. (Each module's outputs show a subset of the stable code it
 * drives: the wires are driven one by one, a holding wire off in its PWM
 * off-time while a contracting one stays on. tests/test_firmware_sim.py
 * checks every pattern against the codes the host sent.)
 */
#define _GNU_SOURCE
#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "avr_ioport.h"
#include "avr_spi.h"
#include "avr_uart.h"
#include "hc595.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_irq.h"
#include "sim_time.h"
#include "uart_pty.h"

#define MAX_MODULES 32
#define MAX_CHIPS ((MAX_MODULES + 1) / 2)

static volatile sig_atomic_t stop_requested;

static avr_t *avr;
static uart_pty_t pty;
static hc595_t part;
static FILE *out; /* the real standard output: the PTY line */
static FILE *logf; /* the pin log */

static int modules = 5;
static int chips = 3;
static uint8_t shift_reg[MAX_CHIPS]; /* [0] = chip 1, nearest the MCU */
static uint8_t storage[MAX_CHIPS];
static int oe_level = 1; /* /OE is pulled up on the board: off until driven low */
static int latch_level = 0;
static unsigned long alerts;
static unsigned long latches;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static unsigned long long now_us(void)
{
    return (unsigned long long)avr_cycles_to_usec(avr, avr->cycle);
}

static int module_code(const uint8_t *chain, int m)
{
    return (chain[m / 2] >> ((m & 1) * 4)) & 0x0F;
}

static int __attribute__((unused)) code_valid(int c)
{
    return c == 0 || c == 3 || c == 6 || c == 9 || c == 12 || c == 15;
}

static void log_state(const char *ev)
{
    unsigned long long t = now_us();
    int on = oe_level == 0;
    fprintf(logf, "t_us=%llu ev=%s oe=%s latched=", t, ev, on ? "on" : "off");
    for (int m = 0; m < modules; m++)
        fprintf(logf, "%s%d", m ? "," : "", module_code(storage, m));
    fprintf(logf, " codes=");
    for (int m = 0; m < modules; m++)
        fprintf(logf, "%s%d", m ? "," : "", on ? module_code(storage, m) : 0);
    fputc('\n', logf);
    if (modules & 1) {
        int spare = module_code(storage, modules);
        if (spare) {
            fprintf(logf, "ALERT t_us=%llu unused outputs of chip %d set (%d)\n", t, chips, spare);
            alerts++;
        }
    }
    fflush(logf);
}

/* A byte leaves the SPI: it enters chip 1, every chip passes its old byte on. */
static void spi_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    for (int k = chips - 1; k > 0; k--)
        shift_reg[k] = shift_reg[k - 1];
    shift_reg[0] = (uint8_t)value;
}

static void latch_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)param;
    int level = value ? 1 : 0;
    if (!latch_level && level) { /* rising edge: storage <- shift register */
        memcpy(storage, shift_reg, sizeof(storage));
        latches++;
        /* the hc595 part holds the last four bytes shifted: chips 1..4 */
        uint32_t expect = 0;
        for (int k = 0; k < chips && k < 4; k++)
            expect |= (uint32_t)shift_reg[k] << (8 * k);
        uint32_t mask = chips >= 4 ? 0xFFFFFFFFu : ((1u << (8 * chips)) - 1u);
        if ((part.value & mask) != expect) {
            fprintf(logf, "ALERT t_us=%llu hc595 part holds %08x, chain model %08x\n", now_us(),
                    part.value & mask, expect);
            alerts++;
        }
        log_state("latch");
    }
    latch_level = level;
    (void)irq;
}

static void oe_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    int level = value ? 1 : 0;
    if (level != oe_level) {
        oe_level = level;
        log_state("oe");
    }
}

static void usage(const char *prog)
{
    fprintf(stderr, "usage: %s [-m MODULES] [-l LOGFILE] [-q] FIRMWARE.elf\n", prog);
}

int main(int argc, char **argv)
{
    const char *log_path = getenv("BHR_SIM_LOG");
    int quiet = 0;
    int opt;
    while ((opt = getopt(argc, argv, "m:l:qh")) != -1) {
        switch (opt) {
        case 'm':
            modules = atoi(optarg);
            break;
        case 'l':
            log_path = optarg;
            break;
        case 'q':
            quiet = 1;
            break;
        default:
            usage(argv[0]);
            return 2;
        }
    }
    if (optind != argc - 1 || modules < 1 || modules > MAX_MODULES) {
        usage(argv[0]);
        return 2;
    }
    const char *elf = argv[optind];
    chips = (modules + 1) / 2;

    /* Keep the real stdout for our own lines; send simavr's chatter to stderr. */
    int out_fd = dup(STDOUT_FILENO);
    if (out_fd < 0 || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
        perror("bhr-sim: dup");
        return 1;
    }
    out = fdopen(out_fd, "w");
    setvbuf(out, NULL, _IOLBF, 0);
    if (log_path && *log_path && strcmp(log_path, "-") != 0) {
        logf = fopen(log_path, "w");
        if (!logf) {
            fprintf(stderr, "bhr-sim: cannot write pin log %s: %s\n", log_path, strerror(errno));
            return 1;
        }
        setvbuf(logf, NULL, _IOLBF, 0);
    } else {
        logf = out;
    }

    elf_firmware_t fw;
    memset(&fw, 0, sizeof(fw));
    if (elf_read_firmware(elf, &fw) != 0) {
        fprintf(stderr, "bhr-sim: cannot load firmware %s (build it with 'make -C firmware')\n", elf);
        return 1;
    }
    if (!fw.mmcu[0])
        strcpy(fw.mmcu, "atmega328p");
    if (!fw.frequency)
        fw.frequency = 16000000;
    avr = avr_make_mcu_by_name(fw.mmcu);
    if (!avr) {
        fprintf(stderr, "bhr-sim: simavr does not know MCU %s\n", fw.mmcu);
        return 1;
    }
    avr_init(avr);
    avr_load_firmware(avr, &fw);

    /* UART0 <-> pty */
    uart_pty_init(avr, &pty);
    if (!pty.pty.slavename[0]) {
        fprintf(stderr, "bhr-sim: cannot create a pseudo-terminal\n");
        return 1;
    }
    uart_pty_connect(&pty, '0');
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(uint32_t)(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

    /* 74HC595 chain on SPI + PB2 (latch) + PB1 (/OE) */
    /* simavr names the ATmega328P's SPI 0 (the number); some cores use '0' */
    avr_irq_t *spi_out = avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ(0), SPI_IRQ_OUTPUT);
    if (!spi_out)
        spi_out = avr_io_getirq(avr, AVR_IOCTL_SPI_GETIRQ('0'), SPI_IRQ_OUTPUT);
    avr_irq_t *latch = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN2);
    avr_irq_t *oe = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN1);
    if (!spi_out || !latch || !oe) {
        fprintf(stderr, "bhr-sim: simavr has no SPI or port B on %s\n", fw.mmcu);
        return 1;
    }
    hc595_init(avr, &part);
    avr_connect_irq(spi_out, part.irq + IRQ_HC595_SPI_BYTE_IN);
    avr_connect_irq(latch, part.irq + IRQ_HC595_IN_LATCH);
    avr_irq_register_notify(spi_out, spi_hook, NULL);
    avr_irq_register_notify(latch, latch_hook, NULL);
    avr_irq_register_notify(oe, oe_hook, NULL);

    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    fflush(stdout); /* simavr's messages (now on stderr) before our first line */
    fprintf(out, "PTY %s\n", pty.pty.slavename);
    fflush(out);
    if (!quiet)
        fprintf(stderr, "bhr-sim: %s on %s at %u Hz, %d modules (%d x 74HC595), UART0 on %s\n", elf, fw.mmcu,
                (unsigned)avr->frequency, modules, chips, pty.pty.slavename);
    fprintf(logf, "# bhr-sim pin log: modules=%d chips=%d; t_us = simulated microseconds; "
                  "codes = what the actuators see (0 while /OE is high)\n", modules, chips);
    log_state("start");

    int state = cpu_Running;
    while (!stop_requested) {
        state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed)
            break;
    }
    fprintf(logf, "t_us=%llu ev=exit latches=%lu alerts=%lu%s\n", now_us(), latches, alerts,
            state == cpu_Crashed ? " crashed=1" : "");
    fflush(logf);
    if (!quiet)
        fprintf(stderr, "bhr-sim: stopped at t=%.6f s (%s)\n", now_us() / 1e6,
                stop_requested ? "signal" : (state == cpu_Crashed ? "firmware crashed" : "firmware stopped"));

    /* remove simavr's /tmp/simavr-uart0 link if it is still ours */
    char target[sizeof(pty.pty.slavename) + 1];
    ssize_t n = readlink("/tmp/simavr-uart0", target, sizeof(target) - 1);
    if (n > 0) {
        target[n] = 0;
        if (strcmp(target, pty.pty.slavename) == 0)
            unlink("/tmp/simavr-uart0");
    }
    /* Not uart_pty_stop(): in simavr 1.6 it stops the bridge thread with a
     * single SIGINT, which is lost when it lands outside select() and then
     * pthread_join() waits forever. select() is a cancellation point. */
    pthread_cancel(pty.thread);
    pthread_join(pty.thread, NULL);
    for (int ti = 0; ti < 2; ti++)
        if (pty.port[ti].s)
            close(pty.port[ti].s);
    if (logf != out)
        fclose(logf);
    fflush(out);
    return state == cpu_Crashed ? 1 : 0;
}
