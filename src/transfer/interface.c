/* interface.c - the interface's functions over the table (transfer.h): lookups by name, tag and
 * kind, and the two calls every runtime makes (the light vector, the light change) through a
 * linear transfer's ops. The table itself is transfer.c's. */
#include "transfer.h"
#include "check.h"
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const transfer_ops *transfer_find(const char *name) {
    for (int i = 0; name && i < transfer_count(); i++)
        if (!strcmp(transfer_at(i)->name, name)) return transfer_at(i);
    return NULL;
}

/* Tag 0 is never a section. */
const transfer_ops *transfer_by_tag(uint32_t tag) {
    for (int i = 0; tag && i < transfer_count(); i++)
        if (transfer_at(i)->tag == tag) return transfer_at(i);
    return NULL;
}

const transfer_ops *transfer_default(transfer_kind kind) {
    for (int i = 0; i < transfer_count(); i++)
        if (transfer_at(i)->kind == kind) return transfer_at(i);
    return NULL;
}

void transfer_names(transfer_kind kind, char *buf, size_t cap) {
    size_t len = 0;
    if (cap) buf[0] = 0;
    for (int i = 0; i < transfer_count() && len < cap; i++)
        if (!kind || transfer_at(i)->kind == kind)
            len += (size_t)snprintf(buf + len, cap - len, "%s%s", len ? ", " : "", transfer_at(i)->name);
}

float (*transfer_light_alloc(void))[4] {
    size_t bytes = sizeof(float) * 4 * CUBE_TEXELS;   /* a multiple of 64, as aligned_alloc requires */
    float (*L)[4] = aligned_alloc(64, bytes);
    if (L) memset(L, 0, bytes);
    return L;
}

float (*transfer_light_vector(const prt_transfer *tr, const float *cube_rgb))[4] {
    PRT_CHECK(tr != NULL && tr->ops->kind == TRANSFER_LINEAR);
    float (*L)[4] = transfer_light_alloc();
    if (!L) return NULL;
    tr->ops->linear->project_light(&tr->cfg, cube_rgb, L);
    return L;
}

float (*transfer_light_scaled_copy(const float (*L)[4], int *shift))[4] {
    float m = 0;
    for (int k = 0; k < CUBE_TEXELS; k++)
        for (int c = 0; c < 3; c++) m = fmaxf(m, fabsf(L[k][c]));
    int e;
    frexpf(m, &e);
    *shift = 0;
    float (*Ls)[4] = e > 96 ? transfer_light_alloc() : NULL;
    if (!Ls) return NULL;
    *shift = e - 96;
    for (int k = 0; k < CUBE_TEXELS; k++)
        for (int c = 0; c < 3; c++) Ls[k][c] = ldexpf(L[k][c], -*shift);
    return Ls;
}

/* A light above about FLT_MAX / 2^21 would overflow the kernels' float sums and turn the vertex
 * black: it runs scaled down by a power of two (exact) and g is scaled back, clamped to the float
 * range. Out of memory for the copy: the light runs unscaled. */
/* The representation's whole-set light when it has one, else its range kernel on the threads. */
static void light_with(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    const transfer_linear *lin = tr->ops->linear;
    if (lin->light) lin->light(tr, t, L, g, nthreads);
    else transport_light_with(t, L, g, nthreads, lin->light_range);
}

void transfer_light(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    PRT_CHECK(tr->ops->kind == TRANSFER_LINEAR);
    int shift;
    float (*Ls)[4] = transfer_light_scaled_copy(L, &shift);
    if (!Ls) {
        light_with(tr, t, L, g, nthreads);
        return;
    }
    light_with(tr, t, (const float (*)[4])Ls, g, nthreads);
    free(Ls);
    for (size_t i = 0; i < 3 * (size_t)t->nvecs; i++) {
        float v = ldexpf(g[i], shift);
        g[i] = isfinite(v) ? v : copysignf(FLT_MAX, g[i]);
    }
}

/* ---- options ---------------------------------------------------------------------------------- */

int transfer_parse_options(const char *who, const transfer_option *opts, const char *text,
                           int (*set)(void *user, int i, const char *value, prt_error *err), void *user, prt_error *err) {
    for (const char *s = text ? text : ""; *s;) {
        size_t len = strcspn(s, ","), klen = strcspn(s, "=,");
        char item[256];
        if (len >= sizeof item) return prt_fail(err, "%s: option '%.40s...' is too long", who, s);
        memcpy(item, s, len);
        item[len] = 0;
        s += len + (s[len] == ',');
        if (len == 0) continue;   /* "a=1,,b=2" and a trailing comma */
        if (klen >= len) return prt_fail(err, "%s: option '%s' has no value (key=value)", who, item);
        item[klen] = 0;
        int i = 0;
        while (opts && opts[i].key && strcmp(opts[i].key, item)) i++;
        if (!opts || !opts[i].key) {
            char keys[256] = "";
            for (int k = 0, n = 0; opts && opts[k].key && n < (int)sizeof keys; k++)
                n += snprintf(keys + n, sizeof keys - (size_t)n, "%s%s", k ? ", " : "", opts[k].key);
            return prt_fail(err, "%s: unknown option '%s' (%s)", who, item, keys[0] ? keys : "it takes none");
        }
        if (set(user, i, item + klen + 1, err)) return -1;
    }
    return 0;
}

int transfer_option_word(const char *who, const transfer_option *o, const char *value, prt_error *err) {
    int k = 0;
    for (const char *w = o->words; w && *w; k++) {
        size_t n = strcspn(w, "|");
        if (strlen(value) == n && !strncmp(w, value, n)) return k;
        w += n + (w[n] == '|');
    }
    return prt_fail(err, "%s: %s = '%s' (must be %s)", who, o->key, value, o->words ? o->words : "nothing");
}

int transfer_option_int(const char *who, const transfer_option *o, const char *value, int *out, prt_error *err) {
    char *end;
    long v = strtol(value, &end, 10);
    if (end == value || *end || v < o->lo || v > o->hi)
        return prt_fail(err, "%s: %s = '%s' (must be %d..%d)", who, o->key, value, o->lo, o->hi);
    *out = (int)v;
    return 0;
}
