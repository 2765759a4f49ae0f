/* uros probe: for windowed code (the ESP32-S3), the libgcc helpers libgcc_lx106.c leaves to libgcc.
 * Debian's lx106 libgcc.a is a call0 build: windowed code that calls into it loses its register window,
 * so the S3's picolibc specs (tests/esp32s3-picolibc-env.sh) link no libgcc and the firmware brings
 * these: 64-bit shifts, unsigned 64-bit division with remainder, signed 64-bit remainder, and float
 * division (through libgcc_lx106.c's double division; a correctly rounded double quotient rounds to the
 * correctly rounded float one). Written with 32-bit shifts only: GCC calls __ashldi3 and the like for
 * 64-bit ones on Xtensa. An empty file for the lx106 (call0: libgcc.a has them). */
#ifdef __XTENSA_WINDOWED_ABI__
#include <stdint.h>

typedef union {
  uint64_t u;
  struct {
    uint32_t lo, hi; /* little-endian */
  } w;
} words;

uint64_t __ashldi3(uint64_t a, int n) {
  words x = {.u = a}, r;
  n &= 63;
  if (n == 0) return a;
  if (n >= 32) {
    r.w.hi = x.w.lo << (n - 32);
    r.w.lo = 0u;
  } else {
    r.w.hi = (x.w.hi << n) | (x.w.lo >> (32 - n));
    r.w.lo = x.w.lo << n;
  }
  return r.u;
}

uint64_t __lshrdi3(uint64_t a, int n) {
  words x = {.u = a}, r;
  n &= 63;
  if (n == 0) return a;
  if (n >= 32) {
    r.w.lo = x.w.hi >> (n - 32);
    r.w.hi = 0u;
  } else {
    r.w.lo = (x.w.lo >> n) | (x.w.hi << (32 - n));
    r.w.hi = x.w.hi >> n;
  }
  return r.u;
}

int64_t __ashrdi3(int64_t a, int n) {
  words x = {.u = (uint64_t)a}, r;
  int32_t hi = (int32_t)x.w.hi;
  n &= 63;
  if (n == 0) return a;
  if (n >= 32) {
    r.w.lo = (uint32_t)(hi >> (n - 32));
    r.w.hi = (uint32_t)(hi >> 31);
  } else {
    r.w.lo = (x.w.lo >> n) | (x.w.hi << (32 - n));
    r.w.hi = (uint32_t)(hi >> n);
  }
  return (int64_t)r.u;
}

uint64_t __udivmoddi4(uint64_t n, uint64_t d, uint64_t *rem) {
  words nn = {.u = n}, dd = {.u = d};
  if (nn.w.hi == 0u && dd.w.hi == 0u && dd.w.lo != 0u) { /* 32-bit: quou/remu */
    if (rem) *rem = nn.w.lo % dd.w.lo;
    return nn.w.lo / dd.w.lo;
  }
  words q = {.u = 0u}, r = {.u = 0u};
  for (int i = 63; i >= 0; i--) { /* restoring division, one bit at a time */
    uint32_t bit = i >= 32 ? (nn.w.hi >> (i - 32)) & 1u : (nn.w.lo >> i) & 1u;
    r.w.hi = (r.w.hi << 1) | (r.w.lo >> 31);
    r.w.lo = (r.w.lo << 1) | bit;
    if (r.u >= d) {
      r.u -= d;
      if (i >= 32) {
        q.w.hi |= 1u << (i - 32);
      } else {
        q.w.lo |= 1u << i;
      }
    }
  }
  if (rem) *rem = r.u;
  return q.u;
}

int64_t __moddi3(int64_t a, int64_t b) {
  uint64_t r;
  __udivmoddi4(a < 0 ? 0u - (uint64_t)a : (uint64_t)a, b < 0 ? 0u - (uint64_t)b : (uint64_t)b, &r);
  return a < 0 ? -(int64_t)r : (int64_t)r;
}

double __divdf3(double a, double b);
double __extendsfdf2(float a);
float __truncdfsf2(double a);
float __divsf3(float a, float b) { return __truncdfsf2(__divdf3(__extendsfdf2(a), __extendsfdf2(b))); }
#else
typedef int uros_probe_libgcc_windowed_unused; /* ISO C wants something in a file */
#endif
