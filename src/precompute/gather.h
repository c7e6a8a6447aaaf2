/* gather.h - interreflection passes by gathering transport vectors (sections
 * 3.2 and 4.2, Eq. 6-8).
 *
 * One pass turns the transport of pass i (T^i, compressed and quantized,
 * decoded on the fly) into pass i+1:
 *   T^{i+1}_k(x) = sum over gather-cube texels w with a hit x~ = x~(x, w):
 *                  [ sum_l h_l(x~, -w) T^i_l(x~) ] g_k(x, w) (n.w) dw          (Eq. 8)
 * The rays come from a global-frame cube map of gather_res (32) per vertex,
 * upper hemisphere only; a ray that hits the scene contributes the complement
 * transport (Eq. 6), one that escapes contributes nothing. T^i at x~ is
 * interpolated from the hit triangle's three vertices with the barycentric
 * weights (more accurate than the paper's nearest vertex by false colour).
 * Weights are first combined per (neighbour vertex, term), so each
 * neighbour's N coefficients are decoded once per vertex. Vertex x's K
 * results are accumulated densely (K x 3 x 24,576 floats per thread), Haar
 * coefficients are already in the wavelet domain (gathering is linear), then
 * truncated to N and quantized into `next`.
 *
 * gather_sum forms direct + bounces: a sparse merge of two sets with the same
 * layout, truncated again to N and requantized.
 *
 * Energy of a set: sum over vectors and channels of the squared coefficients
 * (gather_energy); precompute compares each pass with the direct pass. */
#ifndef PRT_GATHER_H
#define PRT_GATHER_H
#include "prtfile.h"
#include "visibility.h"

typedef struct gather_desc {
    int res;                 /* gather cube resolution; 0: 32 */
    int nthreads;            /* 0: all cores */
    prt_progress_fn progress;
    void *progress_user;
    const char *stage;       /* progress stage name ("bounce 1") */
    struct prt_checkpoint *ckpt; /* non-NULL: vertices of `pass` recorded there are restored, not
                              * gathered, and each gathered vertex is recorded (checkpoint.h) */
    int pass;                /* the checkpoint's pass number (1 for the first bounce) */
    struct prt_shard *shard; /* MPI ranks (shard.h): this rank gathers its range of vertices, cut by cost,
                              * then every rank gets the whole pass; NULL: every vertex here */
    const char *stream_dir;  /* non-NULL: next's staged vectors go through a temporary file there
                              * (transport_stage_to_file; precompute's memory budget), and the finished
                              * next is moved to another (transport_map_to_file); a mapped prev's pages
                              * are dropped from memory every 1% of the pass either way */
    const prt_transport *open; /* prev holds the open sky split (opensky.h): its Lambertian vectors lack g a0(n);
                              * this set holds |p_q| a0(n_q) for the OPENSKY_NORMALS grid normals (one float
                              * vector each, opensky_grid_texels projected), which the pass adds for each such
                              * neighbour with opensky_weights; NULL: prev's vectors are whole */
    const uint8_t *open_vert; /* with open: [nverts], 1 where prev's vectors of vertex v lack the open sky */
    double *cost;            /* [nverts] or NULL: in, each vertex's relative cost (the split); out, the
                              * seconds each took here (every rank's, after the exchange) */
} gather_desc;

/* One pass from prev to next over d's scene and factors (d->transport is ignored).
 * next is initialized here with prev's layout, N and qbits. Returns 0 or -1 (cancelled / OOM). */
int gather_pass(const prt_data *d, const vis_scene *vs, const prt_transport *prev, const gather_desc *desc,
                prt_transport *next, prt_error *err);
/* out = a + b, truncated to N and requantized (a and b share layout). Returns 0 or -1. */
int gather_sum(const prt_transport *a, const prt_transport *b, int nthreads, prt_transport *out, prt_error *err);
/* gather_sum with out staged through, then moved to, temporary files in stream_dir (NULL: in memory,
 * which is gather_sum), as gather_desc.stream_dir does for a pass; the same bits. */
int gather_sum_streamed(const prt_transport *a, const prt_transport *b, int nthreads, const char *stream_dir,
                        prt_transport *out, prt_error *err);
/* Sum of squared dequantized coefficients over all vectors and channels. */
double gather_energy(const prt_transport *t);
#endif
