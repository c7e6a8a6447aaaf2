/* pack.c - a finished set's packed layout (section 4.1.2): transport_finish writes it from the staging,
 * transport_foreach and transport_decode read it back.
 *
 * Contract (transport.h): each vector's staged indices (increasing) become runs of (block, count-1)
 * bytes over the 96 blocks of 256 and one word per coefficient: offset | r<<8 | g<<16 | b<<24 at 8
 * bits, or an offset byte and 16-bit or float values. Staged values are already multiples of the
 * vector's step per channel (store.c, budget.c), so q = value / step is exact.
 *
 * Why runs: the kept indices are sorted and cluster at the start of each face (haar.h's Morton
 * order; SH's low indices), so consecutive coefficients mostly share a block and a run's two bytes
 * replace a block byte per coefficient. Packing is two passes over the vectors (count the runs, then
 * write each vector at its prefix-summed place), both parallel over vectors. */
#include "build.h"
#include <stdlib.h>
#include <string.h>

typedef struct finish_ctx { prt_transport *t; } finish_ctx;

/* Pass 1: number of runs (distinct blocks) of each vector into run_first[i+1]. */
static void count_runs(void *p, int begin, int end, int thread) {
    prt_transport *t = ((finish_ctx *)p)->t;
    for (int i = begin; i < end; i++) {
        const uint32_t *idx = t->stage_idx + (size_t)i * t->N;
        uint32_t n = t->stage_count[i], runs = 0, last = UINT32_MAX;
        for (uint32_t k = 0; k < n; k++) {
            uint32_t blk = idx[k] / SPARSE_BLOCK;
            if (blk != last) { runs++; last = blk; }
        }
        t->run_first[i + 1] = runs;
    }
    transport_release(t, begin, end);
}

/* Pass 2: runs and coefficient words of each vector at its final place. */
static void pack_vectors(void *p, int begin, int end, int thread) {
    prt_transport *t = ((finish_ctx *)p)->t;
    int qmax = sparse_qmax(t->qbits);
    for (int i = begin; i < end; i++) {
        const uint32_t *idx = t->stage_idx + (size_t)i * t->N;
        const float *val = t->stage_val + (size_t)i * t->N * 3;
        const float *sc = t->scale + 3 * (size_t)i;
        uint32_t n = t->stage_count[i], c0 = t->coef_first[i];
        uint8_t *runs = t->runs + 2 * (size_t)t->run_first[i];
        int nr = -1;
        uint32_t last = UINT32_MAX;
        for (uint32_t k = 0; k < n; k++) {
            uint32_t blk = idx[k] / SPARSE_BLOCK, off = idx[k] % SPARSE_BLOCK;
            if (blk != last) {
                nr++;
                runs[2 * nr] = (uint8_t)blk;
                runs[2 * nr + 1] = 0;
                last = blk;
            } else {
                runs[2 * nr + 1]++;
            }
            size_t c = c0 + k;
            if (t->qbits == 8) {
                /* staged values are exactly q * step, so dividing by step recovers q */
                t->packed[c] = sparse_pack8(off, sparse_quantize(val[3 * k], sc[0], qmax),
                                            sparse_quantize(val[3 * k + 1], sc[1], qmax), sparse_quantize(val[3 * k + 2], sc[2], qmax));
            } else if (t->qbits == 16) {
                t->offs[c] = (uint8_t)off;
                for (int ch = 0; ch < 3; ch++) t->q16[3 * c + ch] = (int16_t)sparse_quantize(val[3 * k + ch], sc[ch], qmax);
            } else {
                t->offs[c] = (uint8_t)off;
                memcpy(t->f32 + 3 * c, val + 3 * k, 3 * sizeof(float));
            }
        }
        PRT_CHECK_EQ(nr + 1, (int)(t->run_first[i + 1] - t->run_first[i]));
    }
    transport_release(t, begin, end);
}

/* Compacts the staged vectors; frees staging. Returns 0, or -1 with err set (OOM, overflow). */
int transport_finish(prt_transport *t, prt_error *err) {
    if (!t->stage_count) return 0;
    if (t->stage_key && transport_budget_finish(t, err)) return -1;
    size_t nv = (size_t)t->nvecs;
    t->coef_first = prt_calloc(nv + 1, sizeof *t->coef_first, err);
    t->run_first = prt_calloc(nv + 1, sizeof *t->run_first, err);
    if (!t->coef_first || !t->run_first) goto oom;
    uint64_t total = 0;
    for (size_t i = 0; i < nv; i++) {
        total += t->stage_count[i];
        if (total > UINT32_MAX) {
            free(t->coef_first); free(t->run_first);
            t->coef_first = t->run_first = NULL;
            return prt_fail(err, "transport: more than 2^32 coefficients");
        }
        t->coef_first[i + 1] = (uint32_t)total;
    }
    finish_ctx ctx = { t };
    prt_parallel_for(t->nvecs, 4096, 0, count_runs, &ctx);
    for (size_t i = 0; i < nv; i++) t->run_first[i + 1] += t->run_first[i];
    size_t nc = total, nr = t->run_first[nv];
    t->runs = prt_calloc(2 * nr, 1, err);
    if (!t->runs) goto oom;
    if (t->qbits == 8) t->packed = prt_calloc(nc, sizeof *t->packed, err);
    else t->offs = prt_calloc(nc, 1, err);
    if (t->qbits == 16) t->q16 = prt_calloc(3 * nc, sizeof *t->q16, err);
    if (t->qbits == 32) t->f32 = prt_calloc(3 * nc, sizeof *t->f32, err);
    if (t->qbits == 8 ? !t->packed : (!t->offs || (t->qbits == 16 ? !t->q16 : !t->f32))) goto oom;
    prt_parallel_for(t->nvecs, 4096, 0, pack_vectors, &ctx);
    transport_free_staging(t);
    t->weight = NULL;   /* borrowed for the staging only */
    return 0;
oom:
    /* leave the staged data intact so the caller may retry or free */
    free(t->coef_first); free(t->run_first); free(t->runs); free(t->packed); free(t->offs); free(t->q16); free(t->f32);
    t->coef_first = t->run_first = NULL; t->runs = NULL; t->packed = NULL; t->offs = NULL; t->q16 = NULL; t->f32 = NULL;
    return prt_fail(err, "transport: out of memory compacting %d vectors", t->nvecs);
}

/* Calls fn for every stored coefficient of vector i (after finish), in index order. */
void transport_foreach(const prt_transport *t, int i, void (*fn)(void *ctx, uint32_t index, float r, float g, float b), void *ctx) {
    PRT_CHECK(t->coef_first && i >= 0 && i < t->nvecs);
    const float *sc = t->scale + 3 * (size_t)i;
    size_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t base = (uint32_t)t->runs[2 * r] * SPARSE_BLOCK, cnt = (uint32_t)t->runs[2 * r + 1] + 1;
        for (uint32_t k = 0; k < cnt; k++, c++) {
            if (t->qbits == 8) {
                uint32_t off;
                int qr, qg, qb;
                sparse_unpack8(t->packed[c], &off, &qr, &qg, &qb);
                fn(ctx, base + off, (float)qr * sc[0], (float)qg * sc[1], (float)qb * sc[2]);
            } else if (t->qbits == 16) {
                fn(ctx, base + t->offs[c], t->q16[3 * c] * sc[0], t->q16[3 * c + 1] * sc[1], t->q16[3 * c + 2] * sc[2]);
            } else {
                fn(ctx, base + t->offs[c], t->f32[3 * c], t->f32[3 * c + 1], t->f32[3 * c + 2]);
            }
        }
    }
}

typedef struct decode_ctx { float *r, *g, *b; } decode_ctx;
/* transport_foreach callback: scatters one coefficient into the dense planar arrays. */
static void decode_one(void *p, uint32_t index, float r, float g, float b) {
    decode_ctx *d = p;
    d->r[index] = r; d->g[index] = g; d->b[index] = b;
}

/* Dense planar r,g,b[CUBE_TEXELS] of vector i (zeros where nothing is stored). */
void transport_decode(const prt_transport *t, int i, float *r, float *g, float *b) {
    memset(r, 0, sizeof(float) * CUBE_TEXELS);
    memset(g, 0, sizeof(float) * CUBE_TEXELS);
    memset(b, 0, sizeof(float) * CUBE_TEXELS);
    decode_ctx d = { r, g, b };
    transport_foreach(t, i, decode_one, &d);
}

/* Coefficients stored in all (staged ones before finish). */
size_t transport_ncoefs(const prt_transport *t) {
    if (t->coef_first) return t->coef_first[t->nvecs];
    size_t n = 0;
    if (t->stage_count)
        for (int i = 0; i < t->nvecs; i++) n += t->stage_count[i];
    return n;
}

/* Runs stored in all (0 before finish). */
size_t transport_nruns(const prt_transport *t) { return t->run_first ? t->run_first[t->nvecs] : 0; }

/* Coefficient payload: words (4 B for 8-bit; offset + 6 or 12 B otherwise), 2 B per run,
 * 12 B of scales per vector. */
size_t transport_bytes(const prt_transport *t) {
    size_t nc = transport_ncoefs(t), per = t->qbits == 8 ? 4 : t->qbits == 16 ? 7 : 13;
    return nc * per + 2 * transport_nruns(t) + 12 * (size_t)t->nvecs;
}
