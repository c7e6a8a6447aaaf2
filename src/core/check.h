/* check.h - bug checks: invariants of the library, as pbrt-v4's check.h.
 *
 *     PRT_CHECK(n > 0);                    // abort with the condition, file and line
 *     PRT_CHECK_EQ(t->nvecs, nvecs);       // abort with both values
 *     PRT_CHECK_LE(count, N);  PRT_CHECK_LT(i, n);
 *
 * A failed check is a bug in prt, never bad input (bad input is an error.h
 * error with one line naming the file). Checks stay on in release builds:
 * they guard cheap invariants only (never per coefficient in a hot loop), and
 * a wrong image is worse than an abort. The values are printed as long long
 * or double, so both sides of a comparison show. */
#ifndef PRT_CHECK_H
#define PRT_CHECK_H

/* Prints "prt: bug: FILE:LINE: check failed: EXPR" (with the values, if any) and aborts. */
void prt_check_fail(const char *file, int line, const char *expr, const char *values) __attribute__((noreturn));
/* Formats two values for prt_check_fail (integral and floating operands both print exactly). */
void prt_check_fail2(const char *file, int line, const char *expr, double a, double b) __attribute__((noreturn));

#define PRT_CHECK(cond) do { if (!(cond)) prt_check_fail(__FILE__, __LINE__, #cond, 0); } while (0)
#define PRT_CHECK_OP_(a, op, b) do { double pa_ = (double)(a), pb_ = (double)(b); \
    if (!((a) op (b))) prt_check_fail2(__FILE__, __LINE__, #a " " #op " " #b, pa_, pb_); } while (0)
#define PRT_CHECK_EQ(a, b) PRT_CHECK_OP_(a, ==, b)
#define PRT_CHECK_NE(a, b) PRT_CHECK_OP_(a, !=, b)
#define PRT_CHECK_LT(a, b) PRT_CHECK_OP_(a, <, b)
#define PRT_CHECK_LE(a, b) PRT_CHECK_OP_(a, <=, b)
#define PRT_CHECK_GE(a, b) PRT_CHECK_OP_(a, >=, b)
#endif
