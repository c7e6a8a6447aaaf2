/* probecube.h - a light probe resampled once to a fine cube map, unrotated, from which the
 * lighting cube under any rotation is a cube-to-cube resample: what makes a turning probe cheap.
 *
 * Usage:
 *     probe_cube *pc = probe_cube_create(&probe, &(probe_cube_desc){ 0 }, &err);  // once per probe
 *     probe_cube_resample(pc, R, cube);   // cube[3 * 6 * res^2] for rotation R (NULL: none)
 *     probe_cube_destroy(pc);
 *
 * Why: probe_to_cube (probe.h) evaluates the probe (atan2 and acos per bilinear lookup of a
 * latlong image) at 4 x 4 sub-samples of every texel and scans every probe pixel for suns at each
 * call, so a new rotation costs as much as a new probe. Here the probe is resampled once to a
 * source cube of src_res (probe_to_cube, unrotated: area means, refined near suns, so its power is
 * the probe's), its suns are listed, and a rotation reads that cube: the lookups are divisions, not
 * trigonometry, the sub-sample directions and weights are tabulated once, and the rows run on all
 * threads.
 *
 * The filter. Target texel t under R is the mean of ss x ss sub-samples w_s weighted by the exact
 * solid angles of its sub-squares (normalized by their sum: a constant probe gives that constant),
 * each a bilinear lookup of the source cube at R^T w_s (clamped to the edge within a face: the
 * clamped tents still sum to one over a face). ss = src_res / res puts the sub-samples one source
 * texel apart, where the bilinear tents sum to one over the grid (exactly when the grids line up),
 * so every source texel's power lands in the target whatever the rotation. Target texels that a
 * source texel far brighter than the mean can reach (a sun: probe.c's rule, 16x the mean and 1/1000
 * of the peak) take 4 ss x 4 ss sub-samples, a quarter source texel apart, where the tents' sum is
 * within a fraction of a percent of one whatever their angle. The result is the probe's area mean
 * over each target texel, as probe_to_cube gives, seen through a filter one source texel wider:
 * every texel's light comes from at most one source texel beyond its footprint (tests/test_probe.c
 * bounds light functionals by that distance).
 *
 * Errors: out of memory or a bad desc (src_res not 1 to 8 times res): NULL and one line in
 * err. Thread safety: probe_cube_resample only reads pc, so several threads may resample one cube
 * at once. Ownership: pc owns its texels and tables; the probe may be freed after create. */
#ifndef PRT_PROBECUBE_H
#define PRT_PROBECUBE_H
#include "common.h"
#include "probe.h"

/* Zero fields mean the defaults. */
typedef struct probe_cube_desc {
    int res;        /* target cube resolution (default CUBE_RES, the lighting cube) */
    int src_res;    /* source cube resolution, 1 to 8 times res (default 2 res; res (src_res/res)^2 a multiple of 4) */
    int threads;    /* resample threads (0: prt_thread_count(0)); create uses all */
} probe_cube_desc;

typedef struct probe_cube probe_cube;

/* Resamples p once to the source cube and tabulates the resample; NULL with err. */
probe_cube *probe_cube_create(const prt_probe *p, const probe_cube_desc *desc, prt_error *err);
/* out[3 * 6 * res^2] (cubemap.h's order, interleaved RGB): the probe rotated by R (row-major, a
 * light at d moves to R d as in probe_to_cube; NULL: identity), as described above. */
void probe_cube_resample(const probe_cube *pc, const float R[9], float *out);
/* The target resolution. */
int probe_cube_res(const probe_cube *pc);
/* Frees pc (NULL is fine). */
void probe_cube_destroy(probe_cube *pc);
#endif
