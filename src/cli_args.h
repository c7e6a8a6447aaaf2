/* cli_args.h - small helpers shared by the subcommands' argument parsing. */
#ifndef PRT_CLI_ARGS_H
#define PRT_CLI_ARGS_H
#include <stdbool.h>

/* If argv[*i] equals name, stores the next argument in *val, advances *i and returns 1;
 * returns -1 (after printing "prt CMD: NAME needs a value") when the value is missing; 0 otherwise. */
int cli_opt(const char *cmd, int argc, char **argv, int *i, const char *name, const char **val);
/* Parses an int / float fully; returns false on junk, prints "prt CMD: bad value for NAME: VAL". */
bool cli_int(const char *cmd, const char *name, const char *s, int lo, int hi, int *out);
bool cli_float(const char *cmd, const char *name, const char *s, float lo, float hi, float *out);
/* Parses "WxH". */
bool cli_size(const char *cmd, const char *s, int *w, int *h);
/* Prints "prt CMD: message" to stderr; returns 1. */
int cli_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* True for -h / --help. */
bool cli_is_help(const char *a);
#endif

/* Shared by render / view / reference: loading a probe with warnings, and the light vector. */
#include "probe.h"
/* Loads a probe (layout name or NULL for auto), printing one warning line per clamped kind. Returns 0 or 1 (error printed). */
int cli_load_probe(const char *cmd, const char *path, const char *layout, prt_probe *out);
/* Light vector (CUBE_TEXELS x 4, aligned; free()) for probe p rotated by R (NULL: none), in the
 * basis of the file (sh_order 0: Haar wavelets, 16-bit; else SH). Returns NULL on OOM. */
float (*cli_light_vector(const prt_probe *p, const float *R, int sh_order))[4];
