/* haar_run.h - Haar's configuration and its policy in a precompute (transfer_haar.c's table
 * points at these; private to src/transfer/haar/).
 *
 * The options (transfer_haar.c's table; empty options are what `prt precompute` does):
 *     measure=solid_angle|texels   the wavelets of T/w (default) or of the texels T (the paper's)
 *     select=expected|magnitude    which N a vector keeps: the least expected error under the
 *                                  light's level spectrum or prior (default with solid_angle), or
 *                                  the N largest (the paper's; the only one with texels)
 *     budget=auto|shared|vector|relative   who shares the N x vectors coefficients (transport.h);
 *                                  auto: per vector with a light prior, else shared up to
 *                                  HAAR_SHARED_MAX_VECS vectors, per vector beyond
 *     smooth_faces=on|off          with solid_angle: what truncation drops comes back weighted by
 *                                  the transport on faces with no occluder edge (else per block)
 *     refit=on|off                 with a light prior and a per-vector budget: the kept values
 *                                  refit to the prior's light per texel (refit.h)
 *     texels=rays|box              with a light prior: its brightest texels integrated along rays
 *                                  placed as its light lies inside them (prior.h), or all by box
 *     prior_yaws=1..3600           the yaw angles a light prior's probes are turned through
 *                                  (default PRIOR_STEPS; 1: as they are, a light that does not turn,
 *                                  and no refit, which weighs by the light's variance over the turns)
 *
 * The light prior (transfer_setup.light_prior: the probes the file will mostly be lit by) is built
 * by haar_begin: the probes loaded, their RMS light over the yaw orbit (prior.h), the light-weighted
 * texels and the refit's texel statistics; the budget resolved; the plan's lines written. It needs
 * the expected-error selection: asked for with another one it is refused, given by the scene it is
 * left out with a note. */
#ifndef PRT_HAAR_RUN_H
#define PRT_HAAR_RUN_H
#include "linear.h"

/* budget=auto keeps a shared budget up to this many vectors: a shared budget stages 4N candidates per
 * vector (12.8 KB against 2 KB) and costs about 13% more CPU, so the largest scenes (a 1 M-vertex
 * scene holds 1.1 M vectors) keep the paper's per-vector N. */
#define HAAR_SHARED_MAX_VECS 500000
#define HAAR_BUDGET_AUTO (-1)

typedef struct haar_config {
    linear_config lin;      /* N, qbits, order 0, measure */
    int select;             /* transport_select */
    int budget;             /* HAAR_BUDGET_AUTO or a transport_budget */
    bool smooth_faces;
    bool refit;
    bool box_texels;
    int prior_yaws;         /* 0: PRIOR_STEPS */
} haar_config;

haar_config haar_config_of(const transfer_config *cfg);

/* The Haar light vector of the cube (cube_rgb [CUBE_TEXELS][3]) with or without the solid-angle
 * measure into L (light.h: the paper's threshold, 16-bit quantization). */
void haar_light_vector(const float *cube_rgb, bool solid_angle, float (*L)[4]);

/* The number of probe files in a light prior's comma-separated list, or -1 with err when a name is
 * empty or there are more than PRIOR_MAX_PROBES (a usage error, found before anything is loaded). */
int haar_prior_list(const char *paths, prt_error *err);

/* transfer_linear's precompute hooks (transfer.h). */
int haar_begin(const transfer_config *cfg, const transfer_setup *s, const transfer_linear_in *in, transfer_linear_run *out,
               prt_error *err);
int haar_init_set(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts, const int *nvec,
                  prt_error *err);
void haar_key(const transfer_linear_run *run, transfer_key_fn add, void *key);
void haar_end(transfer_linear_run *run);
#endif
