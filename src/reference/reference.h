/* reference.h - path-traced ground truth for a PRT scene (what Eq. 2 and its
 * interreflection passes, section 3.2, converge to without any approximation).
 *
 * Usage:
 *     ref_ctx *rc = ref_create(&scene, &probe, NULL, &err);   // scene and probe are SHARED: keep alive
 *     ref_desc d = { .spp = 256, .bounces = 0, .seed = 1 };
 *     ref_render_vertices(rc, cam.eye, NULL, scene.mesh.nverts, &d, rgb, se, &err);
 *     ref_render_image(rc, &cam, 800, 600, &d, &img, NULL, &err);
 *     ref_destroy(rc);
 *
 * What it computes. Outgoing radiance toward the eye with the analytic BRDFs
 * (brdf_eval / brdf_sample / brdf_pdf, no factorization), visibility by Embree
 * rays (vis_closest / vis_occluded), and the distant probe at its full
 * resolution (probe_eval, bilinear, rotated by R: a light at d moves to R d).
 * Surfaces are one-sided as in PRT: the shading normal is the interpolated vertex
 * normal, a direction below its horizon gets no light and reflects none; the
 * geometric normal only orients ray offsets (vis_eps). A textured material (texture.h) has its kd
 * multiplied by the texture at each hit's interpolated UV (at a vertex: its own UV). Per vertex (the quantity PRT
 * computes, Eq. 5) the estimate is taken at the vertex position with its normal,
 * rays leaving from p + eps n as in vis_cube.
 *
 * Estimator. Next-event estimation of the environment with multiple importance
 * sampling (power heuristic, Veach 1997) of two strategies: environment sampling
 * from a piecewise-constant distribution over a latitude-longitude grid (the probe's
 * own pixels for a latlong probe; weights luminance x exact cell solid angle, taking
 * the 3x3 neighbourhood maximum into account so that the pdf is positive wherever the
 * bilinear probe is), and BRDF sampling. bounces: 0 = direct only (a PRT file with no
 * bounce passes), k > 0 = at most k indirect bounces (Eq. 8's passes 1..k),
 * -1 = to convergence with Russian roulette after 3 bounces (survival = min(0.95,
 * max throughput)). Emission is the environment and the scene's local lights
 * (scene->lights): at every path vertex each point or spot light is
 * sampled by next-event estimation with a shadow ray (a delta light: no MIS weight,
 * BRDF sampling never hits it), so with --bounces k their indirect light follows too.
 * A black probe (probe_make_constant 0; `--probe none`) leaves the local lights alone.
 *
 * Images: each pixel averages spp camera rays jittered over its area (box filter). Rays
 * that miss the scene show the probe along the pixel-centre ray, as `prt render` draws
 * its background, so background pixels compare equal and only surfaces differ.
 *
 * Noise: each pixel / vertex gets spp independent samples; the standard error is
 * the sample standard deviation / sqrt(spp), per channel. Determinism: sample s
 * of item i uses PCG32 stream i seeded from `seed`, so results do not depend on the
 * thread count or scheduling. Non-finite samples (never expected) are dropped and counted.
 *
 * Errors: -1 with a one-line err (empty scene, OOM, cancelled by the progress callback). */
#ifndef PRT_REFERENCE_H
#define PRT_REFERENCE_H
#include "common.h"
#include "scene.h"
#include "probe.h"
#include "camera.h"

typedef enum ref_strategy {
    REF_MIS = 0,      /* environment + BRDF sampling, power heuristic (default) */
    REF_ENV_ONLY,     /* environment sampling only (tests) */
    REF_BRDF_ONLY     /* BRDF sampling only (tests) */
} ref_strategy;

typedef struct ref_desc {
    int spp;                 /* samples per pixel / vertex; 0: 64 */
    int bounces;             /* 0 direct only; k > 0 at most k bounces; -1 Russian roulette */
    int light_depth;         /* the local lights' light: 0 as bounces; k > 0 at most k - 1 bounces (1 direct
                              * only, 2 one bounce: what prt's local-light effects simulate), the path
                              * going on as long as either count wants it */
    uint64_t seed;
    ref_strategy strategy;
    int nthreads;            /* 0: all cores */
    bool black_background;   /* images: camera rays that miss are black instead of the probe */
    prt_progress_fn progress;
    void *progress_user;
    const char *stage;       /* progress stage name; NULL: "reference" */
} ref_desc;

typedef struct ref_stats {
    double seconds;
    long paths;              /* samples taken */
    long rays;               /* rays traced (closest + occlusion) */
    long dropped;            /* non-finite samples dropped */
    double rel_noise;        /* sqrt(sum stderr^2 / sum value^2) over the output */
} ref_stats;

typedef struct ref_ctx ref_ctx;

/* Builds the BVH and the environment distribution. R: 3x3 row-major light rotation or NULL. */
ref_ctx *ref_create(const prt_scene *scene, const prt_probe *probe, const float R[9], prt_error *err);
void ref_destroy(ref_ctx *rc);

/* Per-vertex outgoing radiance toward eye. verts: vertex ids (NULL: all, n = nverts).
 * rgb[3n], se[3n] (standard errors; may be NULL). stats may be NULL. Returns 0 or -1. */
int ref_render_vertices(const ref_ctx *rc, const float eye[3], const int *verts, int n, const ref_desc *d,
                        float *rgb, float *se, ref_stats *stats, prt_error *err);
/* Image of w x h through cam (camera_ray, jittered in each pixel). out is allocated (image_free).
 * se (may be NULL) receives per-pixel standard errors [w*h*3]. stats may be NULL. */
int ref_render_image(const ref_ctx *rc, const prt_camera *cam, int w, int h, const ref_desc *d, prt_image *out,
                     float *se, ref_stats *stats, prt_error *err);

/* Rows [y0, y1) of that image only, into rgb[3 w (y1 - y0)] (and se, may be NULL, the same size), the
 * same values ref_render_image gives those rows with the same desc (a pixel's samples depend on its
 * index and seed only): a caller can refine an image band by band and stop between bands (the
 * viewer's progressive reference, a new seed per pass). */
int ref_render_rows(const ref_ctx *rc, const prt_camera *cam, int w, int h, int y0, int y1, const ref_desc *d,
                    float *rgb, float *se, ref_stats *stats, prt_error *err);

/* Environment sampling (exposed for tests): direction (world, unit) from u[0..3] in [0,1), with its
 * solid-angle pdf; false for an all-black probe. ref_env_pdf gives the pdf of any world direction. */
bool ref_env_sample(const ref_ctx *rc, const float u[4], float w[3], float *pdf);
float ref_env_pdf(const ref_ctx *rc, const float w[3]);
/* Radiance of the (rotated) environment in world direction w. */
void ref_env_radiance(const ref_ctx *rc, const float w[3], float rgb[3]);

/* True when vertex v's normal faces eye (n . (eye - p) > 0): only then is radiance toward the eye
 * defined for a one-sided surface; ref_render_vertices gives exactly 0 for the others. */
bool ref_vertex_faces(const prt_mesh *m, int v, const float eye[3]);

/* Writes "vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing" atomically, row i for vertex ids[i]
 * (ids NULL: i; se NULL: zeros; facing NULL: all 1). The facing column lets prt compare leave out
 * back-facing vertices (compare.h). */
int ref_write_vertex_csv(const char *path, const int *ids, const float *rgb, const float *se, const uint8_t *facing, int n,
                         prt_error *err);
#endif
