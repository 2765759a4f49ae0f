/* uros probe: bare-metal start-up for QEMU's RISC-V virt machine (rv32, `-bios none`: QEMU jumps to the
 * ELF's entry). Start-up (stack, picolibc's thread pointer for its TLS errno, .data, .bss), a
 * millisecond clock from the CLINT's mtime, the console and _exit through
 * RISC-V semihosting (the machine has one UART: the agent's link), so that QEMU exits with main()'s
 * return value. The machine's numbers come from probe_machine.h (meta/probe/machines.yaml). Generated
 * by uros probe; not a board support package for real hardware. */
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include "probe.h"
#include "probe_machine.h"

int main(void);
void probe_memory_init(const uint8_t *sp);

/* ---- semihosting: the RISC-V sequence (uncompressed, in one page) around ebreak ---- */
__attribute__((noinline, aligned(16))) static uint32_t semihost(uint32_t op, const void *arg) {
  register uint32_t a0 __asm("a0") = op;
  register const void *a1 __asm("a1") = arg;
  __asm volatile(
      ".option push\n .option norvc\n"
      "slli x0, x0, 0x1f\n ebreak\n srai x0, x0, 7\n"
      ".option pop"
      : "+r"(a0)
      : "r"(a1)
      : "memory");
  return a0;
}

static char line[81];
static unsigned line_length;
void probe_console_init(void) {}
void probe_console_put(uint8_t byte) { /* SYS_WRITE0 a line at a time into the console chardev */
  line[line_length++] = (char)byte;
  if (byte == '\n' || line_length == sizeof line - 1) {
    line[line_length] = '\0';
    semihost(0x04u, line);
    line_length = 0;
  }
}

/* What the run's end passes first: nothing for the probe; `uros probe --app`'s runner (app_main.c)
 * writes its end line there and chooses the status QEMU exits with. */
__attribute__((weak)) int probe_exit_status(int status) { return status; }
void _exit(int status) {
  status = probe_exit_status(status);
  /* SYS_EXIT_EXTENDED (0x20) with ADP_Stopped_ApplicationExit: QEMU exits with `status` */
  uint32_t block[2] = {0x20026u, (uint32_t)status};
  semihost(0x20u, block);
  for (;;) {
  }
}

/* ---- time: mtime counts at PROBE_CLOCK_HZ ---- */
static uint64_t mtime(void) {
  volatile uint32_t *t = (volatile uint32_t *)0x0200BFF8u;
  uint32_t hi, lo;
  do {
    hi = t[1];
    lo = t[0];
  } while (hi != t[1]);
  return ((uint64_t)hi << 32) | lo;
}
uint32_t probe_millis(void) { return (uint32_t)(mtime() / (PROBE_CLOCK_HZ / 1000u)); }

int clock_gettime(clockid_t clock, struct timespec *when) {
  (void)clock;
  uint64_t now = mtime();
  when->tv_sec = (time_t)(now / PROBE_CLOCK_HZ);
  when->tv_nsec = (long)((now % PROBE_CLOCK_HZ) * (1000000000u / PROBE_CLOCK_HZ));
  return 0;
}

/* ---- start-up ---- */
void probe_reset(void) {
  uint8_t *sp;
  __asm volatile("mv %0, sp" : "=r"(sp));
  probe_memory_init(sp); /* picolibc.c */
  probe_console_init();
  probe_link_init();
  _exit(main());
}

__attribute__((naked, section(".text.start"))) void probe_start(void) {
  __asm volatile(
#ifdef __riscv_flen
      /* F code (rv32imafc, the ESP32-P4's ISA): the FPU is off after reset (mstatus.FS = Off) and its
       * first instruction would trap: FS = Initial. picolibc's start-up would do the same. */
      "li t0, 0x2000\n"
      "csrs mstatus, t0\n"
#endif
      "la sp, probe_stack_top\n"
      "la tp, probe_tls_base\n" /* picolibc keeps errno in TLS */
      "j probe_reset\n");
}
