/* transfer.c - the table of transfer representations (transfer.h): every
 * implementation is listed here and nowhere else, and the two calls every
 * runtime makes (the light vector, the light change) go through its ops. */
#include "transfer.h"
#include "check.h"
#include "light.h"
#include "prtfile.h"
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Every representation. Adding one: its module (transfer_NAME.c) and one line here. */
static const transfer_ops *const k_transfers[] = {
    &transfer_haar,     /* Haar wavelets, N largest of 24,576, quantized (the paper) */
    &transfer_sh,       /* spherical harmonics of order 3..10 (the low-frequency baseline) */
    &transfer_vmf,      /* vMF lobes per vertex and view, perfect-hashed (laurijssen-2011; issue 9) */
};
#define NTRANSFERS ((int)(sizeof k_transfers / sizeof k_transfers[0]))

int transfer_count(void) { return NTRANSFERS; }

/* The i-th representation (0 <= i < transfer_count()). */
const transfer_ops *transfer_at(int i) {
    PRT_CHECK(i >= 0 && i < NTRANSFERS);
    return k_transfers[i];
}

const transfer_ops *transfer_find(const char *name) {
    for (int i = 0; name && i < NTRANSFERS; i++)
        if (!strcmp(k_transfers[i]->name, name)) return k_transfers[i];
    return NULL;
}

/* Tag 0 is never a section (a representation without one, e.g. per-frame lights). */
const transfer_ops *transfer_by_tag(uint32_t tag) {
    for (int i = 0; tag && i < NTRANSFERS; i++)
        if (k_transfers[i]->tag == tag) return k_transfers[i];
    return NULL;
}

void transfer_names(char *buf, size_t cap) {
    size_t len = 0;
    if (cap) buf[0] = 0;
    for (int i = 0; i < NTRANSFERS && len < cap; i++)
        len += (size_t)snprintf(buf + len, cap - len, "%s%s", i ? ", " : "", k_transfers[i]->name);
}

float (*transfer_light_vector(const struct prt_data *d, const float *cube_rgb))[4] {
    const prt_transfer *tr = prt_data_transfer(d);
    PRT_CHECK(tr != NULL && tr->ops->project_light != NULL);
    float (*L)[4] = light_alloc();
    if (!L) return NULL;
    tr->ops->project_light(&tr->cfg, cube_rgb, L);
    return L;
}

/* A light above about FLT_MAX / 2^21 (a finite sun of 1e37, issue 12) would overflow the kernels'
 * float sums and turn the vertex black: it runs scaled down by a power of two (light_scaled_copy,
 * exact) and g is scaled back, clamped to the float range. */
void transfer_light(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    PRT_CHECK(tr->ops->light_range != NULL);
    int shift;
    float (*Ls)[4] = light_scaled_copy(L, &shift);
    if (!Ls) {   /* the usual case (or out of memory: as before) */
        transport_light_with(t, L, g, nthreads, tr->ops->light_range);
        return;
    }
    transport_light_with(t, (const float (*)[4])Ls, g, nthreads, tr->ops->light_range);
    free(Ls);
    for (size_t i = 0; i < 3 * (size_t)t->nvecs; i++) {
        float v = ldexpf(g[i], shift);
        g[i] = isfinite(v) ? v : copysignf(FLT_MAX, g[i]);
    }
}
