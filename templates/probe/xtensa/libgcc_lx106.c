/* uros probe: the integer division and soft-float helpers that Debian's lx106 libgcc lacks (the
 * ESP8266 has them in ROM): 32-bit division, 64-bit division and multiplication, and IEEE 754 double
 * add, subtract, multiply, divide and conversions, rounding to nearest even. Denormals are flushed to
 * zero and NaN payloads are not kept: enough for what micro-ROS and the probe compute (times,
 * timeouts), not a general floating-point library. Float operations go through double. */
#include <stdint.h>

typedef union {
  double d;
  uint64_t u;
} dbits;
typedef union {
  float f;
  uint32_t u;
} fbits;

/* ---- integers ---- */
uint64_t __udivmoddi4(uint64_t n, uint64_t d, uint64_t *r); /* in libgcc */

uint32_t __udivsi3(uint32_t n, uint32_t d) {
  uint32_t q = 0, r = 0;
  for (int i = 31; i >= 0; i--) {
    r = (r << 1) | ((n >> i) & 1u);
    if (r >= d) {
      r -= d;
      q |= 1u << i;
    }
  }
  return q;
}
uint32_t __umodsi3(uint32_t n, uint32_t d) { return n - __udivsi3(n, d) * d; }
int32_t __divsi3(int32_t n, int32_t d) {
  uint32_t q = __udivsi3(n < 0 ? -(uint32_t)n : (uint32_t)n, d < 0 ? -(uint32_t)d : (uint32_t)d);
  return (n < 0) != (d < 0) ? -(int32_t)q : (int32_t)q;
}
uint64_t __udivdi3(uint64_t n, uint64_t d) { return __udivmoddi4(n, d, 0); }
uint64_t __umoddi3(uint64_t n, uint64_t d) {
  uint64_t r;
  __udivmoddi4(n, d, &r);
  return r;
}
int64_t __divdi3(int64_t n, int64_t d) {
  uint64_t q = __udivdi3(n < 0 ? -(uint64_t)n : (uint64_t)n, d < 0 ? -(uint64_t)d : (uint64_t)d);
  return (n < 0) != (d < 0) ? -(int64_t)q : (int64_t)q;
}

static uint64_t mul32(uint32_t a, uint32_t b) { /* 32 x 32 -> 64 from 16-bit halves */
  uint32_t a0 = a & 0xFFFFu, a1 = a >> 16, b0 = b & 0xFFFFu, b1 = b >> 16;
  uint32_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
  uint32_t mid = (p00 >> 16) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
  uint32_t lo = (p00 & 0xFFFFu) | (mid << 16);
  uint32_t hi = p11 + (p01 >> 16) + (p10 >> 16) + (mid >> 16);
  return ((uint64_t)hi << 32) | lo;
}
uint64_t __umulsidi3(uint32_t a, uint32_t b) { return mul32(a, b); }
uint64_t __muldi3(uint64_t a, uint64_t b) {
  uint32_t al = (uint32_t)a, ah = (uint32_t)(a >> 32), bl = (uint32_t)b, bh = (uint32_t)(b >> 32);
  return mul32(al, bl) + ((uint64_t)(al * bh + ah * bl) << 32);
}

/* ---- doubles: sig holds the leading 1 at bit 62 and 10 rounding bits; the value is
 * sig / 2^62 * 2^(e + 1 - 1023) (SoftFloat's convention) ---- */
#define SIGN(u) ((uint32_t)((u) >> 63))
#define EXP(u) ((int)(((u) >> 52) & 0x7FF))
#define FRAC(u) ((u) & 0x000FFFFFFFFFFFFFull)
#define IMPLICIT 0x0010000000000000ull

static double pack(uint32_t s, int e, uint64_t sig) {
  dbits r;
  r.u = ((uint64_t)s << 63) + ((uint64_t)e << 52) + sig;
  return r.d;
}

static double round_pack(uint32_t s, int e, uint64_t sig) {
  if (e < 0) return pack(s, 0, 0); /* flushed to zero */
  if (e >= 0x7FD && (e > 0x7FD || sig + 0x200 >= 0x8000000000000000ull)) return pack(s, 0x7FF, 0);
  uint32_t round_bits = (uint32_t)(sig & 0x3FF);
  sig = (sig + 0x200) >> 10;
  if (round_bits == 0x200) sig &= ~1ull; /* a tie: to even */
  if (sig == 0) e = 0;
  return pack(s, e, sig);
}

static uint64_t shift_right_sticky(uint64_t v, int n) {
  if (n <= 0) return v;
  if (n >= 64) return v != 0;
  return (v >> n) | ((v << (64 - n)) != 0);
}

static double special(uint64_t a, uint64_t b) { /* an operand is infinite or NaN */
  dbits r;
  r.u = EXP(a) == 0x7FF ? a : b;
  return r.d;
}

static double add_signed(uint64_t a, uint64_t b) {
  if (EXP(a) == 0x7FF || EXP(b) == 0x7FF) return special(a, b);
  if (EXP(a) == 0) {
    dbits r;
    r.u = EXP(b) == 0 ? (a & b & (1ull << 63)) : b;
    return r.d;
  }
  if (EXP(b) == 0) {
    dbits r;
    r.u = a;
    return r.d;
  }
  if (EXP(a) < EXP(b)) {
    uint64_t t = a;
    a = b;
    b = t;
  }
  int e = EXP(a);
  uint64_t ma = (FRAC(a) | IMPLICIT) << 10, mb = shift_right_sticky((FRAC(b) | IMPLICIT) << 10, e - EXP(b));
  uint32_t s = SIGN(a);
  uint64_t m;
  if (SIGN(a) == SIGN(b)) {
    m = ma + mb;
    if (m & 0x8000000000000000ull) {
      m = (m >> 1) | (m & 1);
      e++;
    }
  } else {
    if (ma >= mb) {
      m = ma - mb;
    } else {
      m = mb - ma;
      s = SIGN(b);
    }
    if (m == 0) return pack(0, 0, 0);
    while (!(m & 0x4000000000000000ull)) {
      m <<= 1;
      e--;
    }
  }
  return round_pack(s, e - 1, m);
}

double __adddf3(double a, double b) {
  dbits x = {a}, y = {b};
  return add_signed(x.u, y.u);
}
double __subdf3(double a, double b) {
  dbits x = {a}, y = {b};
  return add_signed(x.u, y.u ^ (1ull << 63));
}

double __muldf3(double a, double b) {
  dbits x = {a}, y = {b};
  uint32_t s = SIGN(x.u) ^ SIGN(y.u);
  if (EXP(x.u) == 0x7FF || EXP(y.u) == 0x7FF) return special(x.u, y.u);
  if (EXP(x.u) == 0 || EXP(y.u) == 0) return pack(s, 0, 0);
  uint64_t ma = FRAC(x.u) | IMPLICIT, mb = FRAC(y.u) | IMPLICIT; /* 53 bits each */
  uint32_t al = (uint32_t)ma, ah = (uint32_t)(ma >> 32), bl = (uint32_t)mb, bh = (uint32_t)(mb >> 32);
  uint64_t lo = mul32(al, bl), mid = mul32(ah, bl) + mul32(al, bh), hi = mul32(ah, bh);
  uint64_t low = lo + (mid << 32);
  uint64_t high = hi + (mid >> 32) + (low < lo);
  int e = EXP(x.u) + EXP(y.u);
  int k = (high >> 41) ? 43 : 42; /* the product is in [2^104, 2^106): its top bit to bit 62 */
  uint64_t sig = (high << (64 - k)) | (low >> k) | ((low << (64 - k)) != 0);
  return round_pack(s, e - (k == 43 ? 0x3FF : 0x400), sig);
}

double __divdf3(double a, double b) {
  dbits x = {a}, y = {b};
  uint32_t s = SIGN(x.u) ^ SIGN(y.u);
  if (EXP(x.u) == 0x7FF) return special(x.u, y.u);
  if (EXP(y.u) == 0x7FF) return pack(s, 0, 0);
  if (EXP(y.u) == 0) return pack(s, 0x7FF, EXP(x.u) == 0 ? 1 : 0); /* x/0: infinity (0/0: NaN) */
  if (EXP(x.u) == 0) return pack(s, 0, 0);
  uint64_t ma = FRAC(x.u) | IMPLICIT, mb = FRAC(y.u) | IMPLICIT, q = 0, r = ma;
  for (int i = 0; i < 63; i++) { /* q = floor(ma / mb * 2^62) */
    q <<= 1;
    if (r >= mb) {
      r -= mb;
      q |= 1;
    }
    r <<= 1;
  }
  int e = EXP(x.u) - EXP(y.u) + 0x3FE;
  if (!(q & 0x4000000000000000ull)) {
    q <<= 1;
    e--;
  }
  return round_pack(s, e, q | (r != 0));
}

static double from_u32(uint32_t s, uint32_t u) {
  if (u == 0) return pack(s, 0, 0);
  int msb = 31;
  while (!(u >> msb)) msb--;
  return round_pack(s, msb + 1022, (uint64_t)u << (62 - msb));
}
double __floatsidf(int32_t i) { return from_u32(i < 0, i < 0 ? -(uint32_t)i : (uint32_t)i); }
double __floatunsidf(uint32_t u) { return from_u32(0, u); }

static uint32_t to_u32(uint64_t u, int *negative, int max_bits) {
  int e = EXP(u) - 1023;
  *negative = (int)SIGN(u);
  if (EXP(u) == 0 || e < 0) return 0;
  if (e >= max_bits) return max_bits == 32 ? 0xFFFFFFFFu : 0x7FFFFFFFu + *negative;
  uint64_t m = FRAC(u) | IMPLICIT;
  return (uint32_t)(e >= 52 ? m << (e - 52) : m >> (52 - e));
}
int32_t __fixdfsi(double a) {
  dbits x = {a};
  int negative;
  uint32_t v = to_u32(x.u, &negative, 31);
  return negative ? -(int32_t)v : (int32_t)v;
}
uint32_t __fixunsdfsi(double a) {
  dbits x = {a};
  int negative;
  uint32_t v = to_u32(x.u, &negative, 32);
  return negative ? 0 : v;
}

double __extendsfdf2(float a) {
  fbits x = {a};
  uint32_t s = x.u >> 31, e = (x.u >> 23) & 0xFF, f = x.u & 0x7FFFFF;
  if (e == 0) return pack(s, 0, 0);
  if (e == 0xFF) return pack(s, 0x7FF, (uint64_t)f << 29);
  return pack(s, (int)e - 127 + 1023, (uint64_t)f << 29);
}

float __truncdfsf2(double a) {
  dbits x = {a};
  fbits r;
  uint32_t s = SIGN(x.u);
  int e = EXP(x.u) - 1023 + 127;
  if (EXP(x.u) == 0x7FF) {
    r.u = (s << 31) | 0x7F800000u | (FRAC(x.u) ? 0x400000u : 0u);
    return r.f;
  }
  if (EXP(x.u) == 0 || e <= 0) {
    r.u = s << 31;
    return r.f;
  }
  uint64_t m = FRAC(x.u) | IMPLICIT; /* 53 bits: keep 24, round on 29 */
  uint32_t rest = (uint32_t)(m & 0x1FFFFFFFu), kept = (uint32_t)(m >> 29);
  if (rest > 0x10000000u || (rest == 0x10000000u && (kept & 1u))) kept++;
  if (kept >> 24) {
    kept >>= 1;
    e++;
  }
  if (e >= 0xFF) {
    r.u = (s << 31) | 0x7F800000u;
    return r.f;
  }
  r.u = (s << 31) | ((uint32_t)e << 23) | (kept & 0x7FFFFFu);
  return r.f;
}

float __addsf3(float a, float b) { return __truncdfsf2(__adddf3(__extendsfdf2(a), __extendsfdf2(b))); }
float __subsf3(float a, float b) { return __truncdfsf2(__subdf3(__extendsfdf2(a), __extendsfdf2(b))); }
float __mulsf3(float a, float b) { return __truncdfsf2(__muldf3(__extendsfdf2(a), __extendsfdf2(b))); }
float __floatsisf(int32_t i) { return __truncdfsf2(__floatsidf(i)); }
float __floatunsisf(uint32_t u) { return __truncdfsf2(__floatunsidf(u)); }
uint32_t __fixunssfsi(float a) { return __fixunsdfsi(__extendsfdf2(a)); }
