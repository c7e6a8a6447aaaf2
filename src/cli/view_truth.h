/* view_truth.h - the progressive path-traced reference `prt view --truth` shows beside the PRT frame.
 *
 * Usage (the viewer's UI thread; one worker thread renders):
 *     truth_view *tv = truth_create(&data.scene, &(truth_desc){ .bounces = 1 }, &err);
 *     truth_set(tv, &(truth_state){ cam, w, h, probe, R, rotated, lights }, "camera");  // every frame
 *     truth_stats st; truth_read(tv, mean, covered, &st);   // the current estimate, its coverage
 *     truth_destroy(tv);
 *
 * What it renders: reference.h's estimator (ref_render_rows) of the scene under the probe rotated by
 * R, with the local lights of the state, seen through the camera at w x h: the same image
 * `prt reference` makes, with bounces and light_depth as the desc says (the viewer passes the
 * file's, so the reference stays the truth of what the file was made for whatever the PRT knobs
 * turn off). Passes of one sample per pixel with a new seed each (pass p: seed p + 1), band by band
 * of rows, accumulate per pixel; before the first full-resolution pass, one pass at a quarter of the
 * resolution (preview) so the panel fills at once. A pixel is covered once a full-resolution pass
 * reached it; the preview never counts as coverage.
 *
 * Restarts: truth_set with a state that differs from the one being rendered (camera, size, probe,
 * rotation, lights) drops every sample and starts again; the band in flight is discarded, so no
 * sample of an old state survives a restart. Bands are sized to take about TRUTH_BAND_S, which
 * bounds how long a restart waits. The tracer's context (ref_create: the BVH, the environment's
 * sampling tables) is made again only when the probe, rotation or lights change, not for a camera move.
 *
 * Noise: the passes alternate between two halves A and B; per pixel and channel, with n_A, n_B samples
 * and means a, b, the variance of the whole mean m is estimated as (a - b)^2 n_A n_B / (n_A + n_B)^2
 * (var(a - b) = s^2 (1/n_A + 1/n_B), var(m) = s^2 / (n_A + n_B)); noise = sqrt(sum var / sum m^2)
 * over the pixels, once two passes have covered them all: the relative standard error of the estimate,
 * on the scale of compare.h's rel_rmse, so a PRT error below it is not measurable.
 *
 * Cost: the worker runs ref_render_rows on one thread at the lowest CPU priority (nice 19), so the
 * PRT frames on the other threads go first; it stops at desc.max_spp.
 *
 * Errors: truth_create NULL with err (OOM); a failing ref_create or render stops the worker until the
 * next state and says why in truth_stats.error. */
#ifndef PRT_VIEW_TRUTH_H
#define PRT_VIEW_TRUTH_H
#include "camera.h"
#include "common.h"
#include "compare.h"
#include "lights.h"
#include "probe.h"
#include "scene.h"

/* Target seconds of one band of rows: the longest a restart waits for the band in flight. */
#define TRUTH_BAND_S 0.05

typedef struct truth_desc {
    int bounces;        /* ref_desc.bounces */
    int light_depth;    /* ref_desc.light_depth */
    int max_spp;        /* stop after this many passes (0: 4096) */
} truth_desc;

/* What the reference is of; compared as a whole to decide a restart. */
typedef struct truth_state {
    prt_camera cam;
    int w, h;
    const prt_probe *probe;     /* SHARED: kept alive and unchanged while set */
    float R[9];
    bool rotated;               /* R applies (else none) */
    prt_lights lights;
} truth_state;

typedef struct truth_stats {
    int spp;            /* full-resolution passes done over every pixel */
    double covered;     /* share of the pixels with at least one sample */
    double noise;       /* relative standard error of the mean (header); < 0 before two passes */
    double seconds;     /* since the last restart */
    long restarts;      /* restarts so far (the first start not counted) */
    long samples;       /* pixel samples accumulated since the last restart (changes when anything new arrives) */
    const char *why;    /* what caused the last restart (static text) */
    char error[1024];   /* non-empty: the worker stopped on this */
} truth_stats;

typedef struct truth_view truth_view;

/* Starts the worker for scene sc (SHARED: its mesh, materials and textures are read while it runs;
 * its lights are not: the state's are used). NULL with err. */
truth_view *truth_create(const prt_scene *sc, const truth_desc *d, prt_error *err);
/* Stops the worker and frees everything; NULL is fine. */
void truth_destroy(truth_view *tv);
/* The state the reference should show; a different one from the current restarts it (why: its cause). */
void truth_set(truth_view *tv, const truth_state *s, const char *why);
/* The current estimate: mean[3 w h] (top row first; the preview where not covered, zeros before it),
 * covered[w h] (1 where a full-resolution sample is), and st. Sizes are the last truth_set's. */
void truth_read(truth_view *tv, float *mean, uint8_t *covered, truth_stats *st);
/* The counters of truth_read (spp, covered, restarts, samples, seconds, why, error) without the image
 * or the noise: cheap, for a caller that only wants to know whether anything changed. */
void truth_peek(truth_view *tv, truth_stats *st);
/* Blocks until spp passes are done over every pixel, the worker stopped, or timeout_s passed; true
 * when the passes are done. */
bool truth_wait(truth_view *tv, int spp, double timeout_s);

/* ---------------------------------------------------------------- the panels' pixels (w x h, top row first) */

/* Rows of the error panel's scale bar above its bottom edge; the error-vs-time plot's size in pixels. */
#define TRUTH_BAR_Y 24
#define TRUTH_PLOT_W 160
#define TRUTH_PLOT_H 90

/* A setting tried: its PRT frame time and its error against the reference (rel_rmse). */
typedef struct truth_point { float ms, err; char label[48]; } truth_point;

/* compare.h's metrics of prt against ref over the covered pixels only (cov[i] != 0) into res, and
 * each pixel's relative error into e[w h] (may be NULL; -1 where not covered). -1 with err when no
 * pixel is covered or cmp_arrays refuses (reference all zero). */
int truth_compare(const float *prt, const float *ref, const uint8_t *cov, int w, int h, cmp_result *res, float *e,
                  prt_error *err);
/* rgb[3n] linear radiance -> rgba[4n] 8-bit sRGB codes with exposure (clamp), image_write's PNG curve. */
void truth_tonemap(const float *rgb, size_t n, float exposure_stops, uint8_t *rgba);
/* e[w h] (truth_compare) -> rgba: compare.h's error colour map (turbo over log10 e in [-3, 0]; grey where
 * not covered) and its scale bar TRUTH_BAR_Y rows above the bottom, 0.1 % at the left, 100 % at the right. */
void truth_error_rgba(const float *e, int w, int h, uint8_t *rgba);
/* The plot's top row in a panel of height h: above the scale bar's labels, with two label lines below it. */
#define TRUTH_PLOT_Y(h) ((h) - TRUTH_BAR_Y - 72 - TRUTH_PLOT_H)
/* The plot's axes: frame time from 0 to ms_max, error from err_min to err_max (the points' range, padded). */
typedef struct truth_plot_range { float ms_max, err_min, err_max; } truth_plot_range;
/* The error-vs-frame-time plot of pts[n] (pts[cur] highlighted) into rgba at the right, from row
 * TRUTH_PLOT_Y (TRUTH_PLOT_W x TRUTH_PLOT_H), its axes into r for the labels. */
void truth_plot(uint8_t *rgba, int w, int h, const truth_point *pts, int n, int cur, truth_plot_range *r);
#endif
