/* view_truth.c - the progressive reference of `prt view --truth` (view_truth.h): a worker thread
 * refining reference.h's image band by band, restarted when what it shows changes.
 *
 * Ownership: the UI thread writes want (and want_gen, why, quit) under lock; the worker alone
 * writes the accumulation (sum, cnt, preview, pass, row, counters) under lock, and alone touches
 * its ref_ctx and its copy of the scene. A band is rendered without the lock into the worker's
 * buffer and added only if no restart was asked for meanwhile (gen unchanged). */
#include "view_truth.h"
#include "reference.h"
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#define TRUTH_MAX_SPP 4096
#define TRUTH_PREVIEW 4     /* the preview's pixels are TRUTH_PREVIEW x TRUTH_PREVIEW full ones */

struct truth_view {
    const prt_scene *scene;
    truth_desc d;
    pthread_t thread;
    bool started;
    pthread_mutex_t lock;
    pthread_cond_t cond;        /* the worker waits on it for work; truth_wait for progress */
    truth_state want;           /* UI thread: the state asked for ... */
    long want_gen;              /* ... and its number, bumped when it changes */
    const char *why;
    bool quit;
    /* worker, read under lock by the UI thread: */
    long acc_gen;               /* the state the accumulation is of */
    int w, h, pw, ph;           /* its size, the preview's */
    float *sum[2];              /* [3 w h] per half */
    int *cnt[2];                /* [w h] per half */
    float *preview;             /* [3 pw ph] */
    bool have_preview;
    int pass, row;              /* the next band: pass (0-based) and its first row */
    double t0, row_s;           /* restart time; seconds per row of the last band */
    long restarts, samples;
    const char *acc_why;
    char error[1024];
    /* worker only: */
    prt_scene sc;               /* the scene with the state's lights */
    ref_ctx *ctx;               /* built for ctx_of's probe, rotation and lights (a camera move keeps it) */
    truth_state ctx_of;
};

/* Whether two states light the scene alike: the same probe, rotation and local lights (what ref_create
 * builds from; the camera and size are each render's). */
static bool same_lighting(const truth_state *a, const truth_state *b) {
    if (a->probe != b->probe || a->rotated != b->rotated || (a->rotated && memcmp(a->R, b->R, sizeof a->R))) return false;
    return a->lights.count == b->lights.count && !memcmp(a->lights.light, b->lights.light, sizeof(prt_light) * (size_t)a->lights.count);
}

/* Sizes and zeroes the accumulation for the wanted state (lock held; the worker). -1 on OOM. */
static int restart_locked(truth_view *tv) {
    int w = tv->want.w, h = tv->want.h;
    size_t n = (size_t)w * h;
    if (w != tv->w || h != tv->h) {
        for (int k = 0; k < 2; k++) {
            free(tv->sum[k]); free(tv->cnt[k]);
            tv->sum[k] = malloc(3 * n * sizeof(float));
            tv->cnt[k] = malloc(n * sizeof(int));
        }
        tv->pw = (w + TRUTH_PREVIEW - 1) / TRUTH_PREVIEW;
        tv->ph = (h + TRUTH_PREVIEW - 1) / TRUTH_PREVIEW;
        free(tv->preview);
        tv->preview = malloc(3 * (size_t)tv->pw * tv->ph * sizeof(float));
        tv->w = w;
        tv->h = h;
    }
    if (!tv->sum[0] || !tv->sum[1] || !tv->cnt[0] || !tv->cnt[1] || !tv->preview) return -1;
    for (int k = 0; k < 2; k++) {
        memset(tv->sum[k], 0, 3 * n * sizeof(float));
        memset(tv->cnt[k], 0, n * sizeof(int));
    }
    if (tv->acc_gen > 0) tv->restarts++;
    tv->error[0] = 0;   /* a new state tries again */
    tv->acc_gen = tv->want_gen;
    tv->acc_why = tv->why;
    tv->have_preview = false;
    tv->pass = tv->row = 0;
    tv->samples = 0;
    tv->t0 = prt_now();
    return 0;
}

/* Rows of the next band: about TRUTH_BAND_S at the last band's pace, within the pass. */
static int band_rows(const truth_view *tv) {
    int rows = tv->row_s > 0 ? (int)(TRUTH_BAND_S / tv->row_s) : 1;
    if (rows < 1) rows = 1;
    return rows < tv->h - tv->row ? rows : tv->h - tv->row;
}

/* Adds a rendered band (rows [y0, y0 + rows) of pass p) to its half (lock held). */
static void accumulate(truth_view *tv, int p, int y0, int rows, const float *buf) {
    float *s = tv->sum[p & 1] + 3 * (size_t)y0 * tv->w;
    int *c = tv->cnt[p & 1] + (size_t)y0 * tv->w;
    size_t n = (size_t)rows * tv->w;
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++) s[3 * i + k] += buf[3 * i + k];
        c[i]++;
    }
    tv->samples += (long)n;
    tv->row = y0 + rows;
    if (tv->row >= tv->h) { tv->row = 0; tv->pass = p + 1; }
}

/* Renders the band job describes without the lock (a new ref_ctx first when the lighting changed);
 * 0, or -1 with err. */
typedef struct band_job { truth_state st; int pass, y0, rows; bool preview; } band_job;
static int render_band(truth_view *tv, const band_job *j, float *buf, prt_error *err) {
    if (!tv->ctx || !same_lighting(&tv->ctx_of, &j->st)) {
        ref_destroy(tv->ctx);
        tv->sc = *tv->scene;
        tv->sc.lights = j->st.lights;
        tv->ctx_of = j->st;
        tv->ctx = ref_create(&tv->sc, j->st.probe, j->st.rotated ? j->st.R : NULL, err);
        if (!tv->ctx) return -1;
    }
    int threads = prt_thread_count(0) > 1 ? prt_thread_count(0) - 1 : 1;
    ref_desc rd = { .spp = 1, .bounces = tv->d.bounces, .light_depth = tv->d.light_depth, .nthreads = threads,
                    .seed = j->preview ? 0x7275746855ull : (uint64_t)j->pass + 1 };
    if (j->preview) {
        int pw = (j->st.w + TRUTH_PREVIEW - 1) / TRUTH_PREVIEW, ph = (j->st.h + TRUTH_PREVIEW - 1) / TRUTH_PREVIEW;
        return ref_render_rows(tv->ctx, &j->st.cam, pw, ph, 0, ph, &rd, buf, NULL, NULL, err);
    }
    return ref_render_rows(tv->ctx, &j->st.cam, j->st.w, j->st.h, j->y0, j->y0 + j->rows, &rd, buf, NULL, NULL, err);
}

/* The next band to render into j (lock held), restarting first when asked; false: nothing to do. */
static bool next_band(truth_view *tv, band_job *j) {
    if (tv->acc_gen != tv->want_gen && restart_locked(tv)) {
        snprintf(tv->error, sizeof tv->error, "out of memory");
        return false;
    }
    int max = tv->d.max_spp > 0 ? tv->d.max_spp : TRUTH_MAX_SPP;
    if (tv->error[0] || tv->pass >= max || tv->w < 1) return false;
    j->st = tv->want;
    j->preview = !tv->have_preview;
    j->pass = tv->pass;
    j->y0 = tv->row;
    j->rows = j->preview ? 0 : band_rows(tv);
    return true;
}

/* The worker: bands until quit, at the lowest priority so the PRT frames go first. */
static void *truth_main(void *arg) {
    truth_view *tv = arg;
    (void)setpriority(PRIO_PROCESS, (id_t)syscall(SYS_gettid), 19);
    float *buf = NULL;
    size_t cap = 0;
    pthread_mutex_lock(&tv->lock);
    while (!tv->quit) {
        band_job j;
        if (!next_band(tv, &j)) { pthread_cond_wait(&tv->cond, &tv->lock); continue; }
        long gen = tv->acc_gen;
        size_t need = 3 * (size_t)tv->w * (j.preview ? (size_t)tv->ph : (size_t)j.rows);
        pthread_mutex_unlock(&tv->lock);
        prt_error err = { { 0 } };
        double t0 = prt_now();
        if (need > cap) { free(buf); buf = malloc(need * sizeof(float)); cap = buf ? need : 0; }
        int rc = buf ? render_band(tv, &j, buf, &err) : prt_fail(&err, "out of memory");
        double dt = prt_now() - t0;
        pthread_mutex_lock(&tv->lock);
        if (rc) { snprintf(tv->error, sizeof tv->error, "%s", err.msg); continue; }
        if (gen != tv->want_gen) continue;   /* a restart was asked for: the band is of the old state */
        if (j.preview) {
            memcpy(tv->preview, buf, 3 * (size_t)tv->pw * tv->ph * sizeof(float));
            tv->have_preview = true;
        } else {
            tv->row_s = dt / j.rows;
            accumulate(tv, j.pass, j.y0, j.rows, buf);
        }
        pthread_cond_broadcast(&tv->cond);
    }
    pthread_mutex_unlock(&tv->lock);
    free(buf);
    return NULL;
}

/* See view_truth.h. */
truth_view *truth_create(const prt_scene *sc, const truth_desc *d, prt_error *err) {
    truth_view *tv = prt_calloc(1, sizeof *tv, err);
    if (!tv) return NULL;
    tv->scene = sc;
    tv->d = *d;
    pthread_mutex_init(&tv->lock, NULL);
    pthread_cond_init(&tv->cond, NULL);
    if (pthread_create(&tv->thread, NULL, truth_main, tv) != 0) {
        truth_destroy(tv);
        return prt_fail(err, "view: cannot start the reference's thread"), NULL;
    }
    tv->started = true;
    return tv;
}

/* See view_truth.h. */
void truth_destroy(truth_view *tv) {
    if (!tv) return;
    if (tv->started) {
        pthread_mutex_lock(&tv->lock);
        tv->quit = true;
        pthread_cond_broadcast(&tv->cond);
        pthread_mutex_unlock(&tv->lock);
        pthread_join(tv->thread, NULL);
    }
    ref_destroy(tv->ctx);
    for (int k = 0; k < 2; k++) { free(tv->sum[k]); free(tv->cnt[k]); }
    free(tv->preview);
    pthread_mutex_destroy(&tv->lock);
    pthread_cond_destroy(&tv->cond);
    free(tv);
}

/* Whether two states give the same image. */
static bool same_state(const truth_state *a, const truth_state *b) {
    if (memcmp(&a->cam, &b->cam, sizeof a->cam) || a->w != b->w || a->h != b->h || a->probe != b->probe) return false;
    if (a->rotated != b->rotated || (a->rotated && memcmp(a->R, b->R, sizeof a->R))) return false;
    return a->lights.count == b->lights.count && !memcmp(a->lights.light, b->lights.light, sizeof(prt_light) * (size_t)a->lights.count);
}

/* See view_truth.h. */
void truth_set(truth_view *tv, const truth_state *s, const char *why) {
    pthread_mutex_lock(&tv->lock);
    if (tv->want_gen == 0 || !same_state(&tv->want, s)) {
        tv->want = *s;
        tv->want_gen++;
        tv->why = why;
        pthread_cond_broadcast(&tv->cond);
    }
    pthread_mutex_unlock(&tv->lock);
}

/* The noise of the mean (header) over covered pixels with samples in both halves (lock held). */
static double noise_locked(const truth_view *tv) {
    if (tv->pass < 2) return -1;   /* until both halves cover every pixel it would be of some pixels only */
    double var = 0, m2 = 0;
    bool any = false;
    for (size_t i = 0; i < (size_t)tv->w * tv->h; i++) {
        double na = tv->cnt[0][i], nb = tv->cnt[1][i];
        if (na == 0 || nb == 0) continue;
        any = true;
        for (int k = 0; k < 3; k++) {
            double a = tv->sum[0][3 * i + k] / na, b = tv->sum[1][3 * i + k] / nb, m = (a * na + b * nb) / (na + nb);
            var += (a - b) * (a - b) * na * nb / ((na + nb) * (na + nb));
            m2 += m * m;
        }
    }
    return any && m2 > 0 ? sqrt(var / m2) : -1;
}

/* The counters into st (lock held). */
static void counters_locked(const truth_view *tv, truth_stats *st) {
    memset(st, 0, sizeof *st);
    bool current = tv->acc_gen == tv->want_gen;
    st->spp = current ? tv->pass : 0;
    st->noise = -1;
    st->seconds = current ? prt_now() - tv->t0 : 0;
    st->restarts = tv->restarts + (current ? 0 : 1);   /* a restart asked for counts at once */
    st->samples = current ? tv->samples : 0;
    st->why = current ? tv->acc_why : tv->why;
    long cov = 0;
    size_t n = current ? (size_t)tv->w * tv->h : 0;
    for (size_t i = 0; i < n; i++) cov += tv->cnt[0][i] + tv->cnt[1][i] > 0;
    st->covered = n ? (double)cov / (double)n : 0;
    snprintf(st->error, sizeof st->error, "%s", tv->error);
}

/* See view_truth.h. */
void truth_peek(truth_view *tv, truth_stats *st) {
    pthread_mutex_lock(&tv->lock);
    counters_locked(tv, st);
    pthread_mutex_unlock(&tv->lock);
}

/* See view_truth.h. */
void truth_read(truth_view *tv, float *mean, uint8_t *covered, truth_stats *st) {
    pthread_mutex_lock(&tv->lock);
    counters_locked(tv, st);
    bool current = tv->acc_gen == tv->want_gen;
    int w = tv->want.w, h = tv->want.h;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            int n = current ? tv->cnt[0][i] + tv->cnt[1][i] : 0;
            covered[i] = n > 0;
            const float *p = current && tv->have_preview ? tv->preview + 3 * ((size_t)(y / TRUTH_PREVIEW) * tv->pw + x / TRUTH_PREVIEW) : NULL;
            for (int k = 0; k < 3; k++)
                mean[3 * i + k] = n ? (tv->sum[0][3 * i + k] + tv->sum[1][3 * i + k]) / (float)n : p ? p[k] : 0.0f;
        }
    if (current) st->noise = noise_locked(tv);
    pthread_mutex_unlock(&tv->lock);
}

/* See view_truth.h. */
bool truth_wait(truth_view *tv, int spp, double timeout_s) {
    double until = prt_now() + timeout_s;
    pthread_mutex_lock(&tv->lock);
    bool done;
    while (!(done = tv->acc_gen == tv->want_gen && tv->pass >= spp) && !tv->error[0] && prt_now() < until) {
        pthread_mutex_unlock(&tv->lock);
        usleep(2000);
        pthread_mutex_lock(&tv->lock);
    }
    pthread_mutex_unlock(&tv->lock);
    return done;
}

/* ---------------------------------------------------------------- the panels' pixels */

/* See view_truth.h. */
int truth_compare(const float *prt, const float *ref, const uint8_t *cov, int w, int h, cmp_result *res, float *e,
                  prt_error *err) {
    size_t n = (size_t)w * h, m = 0;
    float *a = malloc(3 * n * sizeof(float) + 1), *b = malloc(3 * n * sizeof(float) + 1), *ec = malloc(n * sizeof(float) + 1);
    int rc = a && b && ec ? 0 : prt_fail(err, "out of memory");
    for (size_t i = 0; !rc && i < n; i++)
        if (cov[i]) {
            memcpy(a + 3 * m, prt + 3 * i, 3 * sizeof(float));
            memcpy(b + 3 * m, ref + 3 * i, 3 * sizeof(float));
            m++;
        }
    memset(res, 0, sizeof *res);
    if (!rc && m == 0) rc = prt_fail(err, "no pixel covered yet");
    if (!rc) rc = cmp_arrays(a, b, (long)m, 3, res, ec, err);
    for (size_t i = 0, k = 0; e && i < n; i++) e[i] = cov[i] && !rc ? ec[k++] : -1.0f;
    free(a);
    free(b);
    free(ec);
    return rc;
}

/* 8-bit sRGB code of a display value in [0, 1] (clamped). */
static uint8_t srgb_code(float x) {
    x = x < 0 ? 0 : x > 1 ? 1 : x;
    float s = x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1 / 2.4f) - 0.055f;
    return (uint8_t)lroundf(s * 255);
}

/* See view_truth.h. */
void truth_tonemap(const float *rgb, size_t n, float exposure_stops, uint8_t *rgba) {
    float k = exp2f(exposure_stops);
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) rgba[4 * i + c] = srgb_code(rgb[3 * i + c] * k);
        rgba[4 * i + 3] = 255;
    }
}

/* The colour of relative error e on compare.h's scale (log10 e from -3 to 0) as display values. */
static void error_colour(float e, uint8_t out[4]) {
    float t = e > 0 ? (float)((log10(e) + 3.0) / 3.0) : 0.f, rgb[3];
    cmp_colormap(t < 0 ? 0 : t > 1 ? 1 : t, rgb);
    for (int c = 0; c < 3; c++) out[c] = (uint8_t)lroundf(255 * (rgb[c] < 0 ? 0 : rgb[c] > 1 ? 1 : rgb[c]));
    out[3] = 255;
}

/* See view_truth.h. */
void truth_error_rgba(const float *e, int w, int h, uint8_t *rgba) {
    for (size_t i = 0; i < (size_t)w * h; i++) {
        if (e[i] < 0) { rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = 40; rgba[4 * i + 3] = 255; }
        else error_colour(e[i], rgba + 4 * i);
    }
    /* The scale bar along the bottom: 0.1 % at the left to 100 % at the right (labels: the caller's). */
    int x0 = 10, x1 = w - 10, y0 = h - TRUTH_BAR_Y, y1 = y0 + 10;
    for (int y = y0 > 0 ? y0 : 0; y < y1 && y < h; y++)
        for (int x = x0; x < x1; x++) error_colour(powf(10.0f, -3.0f + 3.0f * (float)(x - x0) / (float)(x1 - x0)), rgba + 4 * ((size_t)y * w + x));
}

/* One filled square of side 2r + 1 at (x, y), clipped. */
static void dot(uint8_t *rgba, int w, int h, int x, int y, int r, const uint8_t c[3]) {
    for (int j = y - r; j <= y + r; j++)
        for (int i = x - r; i <= x + r; i++)
            if (i >= 0 && j >= 0 && i < w && j < h) memcpy(rgba + 4 * ((size_t)j * w + i), c, 3);
}

/* See view_truth.h. */
void truth_plot(uint8_t *rgba, int w, int h, const truth_point *pts, int n, int cur, truth_plot_range *r) {
    r->ms_max = 1e-3f;
    r->err_min = n ? pts[0].err : 0;
    r->err_max = n ? pts[0].err : 1;
    for (int i = 0; i < n; i++) {
        r->ms_max = fmaxf(r->ms_max, pts[i].ms);
        r->err_min = fminf(r->err_min, pts[i].err);
        r->err_max = fmaxf(r->err_max, pts[i].err);
    }
    float pad = fmaxf(0.1f * (r->err_max - r->err_min), 0.02f * r->err_max + 1e-6f);   /* a lone value mid-height */
    r->err_min = fmaxf(0.0f, r->err_min - pad);
    r->err_max += pad;
    int px0 = w - TRUTH_PLOT_W - 10, py0 = TRUTH_PLOT_Y(h);
    if (px0 < 0 || py0 < 0) return;
    static const uint8_t bg[3] = { 20, 20, 20 }, axis[3] = { 160, 160, 160 }, old[3] = { 120, 200, 255 }, now[3] = { 255, 255, 255 };
    for (int y = py0; y < py0 + TRUTH_PLOT_H && y < h; y++)
        for (int x = px0; x < px0 + TRUTH_PLOT_W; x++) memcpy(rgba + 4 * ((size_t)y * w + x), bg, 3);
    for (int x = px0; x < px0 + TRUTH_PLOT_W; x++) dot(rgba, w, h, x, py0 + TRUTH_PLOT_H - 1, 0, axis);
    for (int y = py0; y < py0 + TRUTH_PLOT_H; y++) dot(rgba, w, h, px0, y, 0, axis);
    for (int i = 0; i < n; i++) {
        int x = px0 + 4 + (int)lroundf((TRUTH_PLOT_W - 8) * pts[i].ms / r->ms_max);
        int y = py0 + TRUTH_PLOT_H - 4 - (int)lroundf((TRUTH_PLOT_H - 8) * (pts[i].err - r->err_min) / (r->err_max - r->err_min));
        dot(rgba, w, h, x, y, i == cur ? 2 : 1, i == cur ? now : old);
    }
}
