/* linear.h - what the linear representations stored as sparse coefficient sets share (Haar, SH
 * and any member that keeps its N best coefficients of a CUBE_TEXELS index space in a
 * prt_transport, transport.h): the leading fields of their private configuration, its defaults,
 * the file section, the validation of every index, the default set setup, and the GLSL light
 * kernels. A member's transfer_ops and transfer_linear tables point at these.
 *
 * Usage (a member's module):
 *     typedef struct my_config { linear_config lin; int mine; } my_config;   // linear_config first
 *     static int my_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
 *         my_config c = { 0 };
 *         if (linear_configure(s, &c.lin, err)) return -1;                 // N, qbits
 *         ... parse s->options (transfer_parse_options) ...
 *         return linear_store(cfg, &c, sizeof c), 0;
 *     }
 *     .write = linear_write, .read = linear_read, .release = linear_release, .bytes = linear_bytes,
 *     .validate = my_validate (linear_validate with its index limit),
 *     linear table: .init_set = linear_init_set, .compress = linear_compress,
 *                   .light_range = transport_light_range, .glsl = &linear_glsl
 *
 * Section layout (little-endian; the tag is the member's):
 *     i32 N, i32 qbits, i32 order        the leading config fields
 *     u64 materials                      bit i: material i
 *     u8  flags                          bit 0: the direct-only set follows the total;
 *                                        bit 1: the solid-angle measure (LINEAR_MEASURE_SOLID_ANGLE);
 *                                        bit 2: padded (below);
 *                                        bit 3: the open sky split (prt_transfer.open_sky)
 *     transport, [direct transport]      each: i32 nverts, nvecs, N, qbits; u64 ncoefs, nruns;
 *                                        vec_first, coef_first, run_first, runs, scale,
 *                                        [padded: u8 k, k zero bytes], then
 *                                        packed (8-bit) or offs + q16 / f32
 *     [open sky: u8 open_vert[nverts]]   1 where a vertex's vectors are split (prt_transfer.open_vert)
 * The padding puts packed, q16 or f32 at a multiple of 64 bytes from the file's start, so that
 * prtfile_read can leave the coefficients in the file's pages: the runs and the coefficient
 * arrays, all but about 24 bytes per vector, become one read-only window of the file
 * (prtio_map_window, kept in the set's data_map as transport_map_to_file's are) instead of a copy.
 * A reader with no file (bytes in memory), a big-endian host, or a file whose array falls on an
 * odd address (no padding bit) copies them: the same values either way.
 * Reading sizes and allocates (or maps) only; linear_validate then checks every index the
 * runtimes follow: per-vertex vector counts against each material's K (0 for materials outside
 * the mask), coefficient and run offsets, blocks, strictly ascending indices below the member's
 * limit, finite values. */
#ifndef PRT_LINEAR_H
#define PRT_LINEAR_H
#include "transfer.h"

/* What the member's coefficients approximate where it has the choice (Haar, transfer_haar.c says
 * why): 0 the texels T_j of Eq. 3, which carry their solid angle, or the transport per steradian
 * T_j / w_j against a light vector of L_j w_j. The file stores which (flag bit 1). */
#define LINEAR_MEASURE_SOLID_ANGLE 1
/* N when the setup gives none: the paper's budget for a 64x64x6 cube. */
#define LINEAR_DEFAULT_N 128

/* The leading fields of every member's private configuration (what the section stores). */
typedef struct linear_config {
    int N;          /* coefficients kept per vector (the mean with a shared budget) */
    int qbits;      /* 8, 16 or 32 (float) */
    int order;      /* the basis size where it has one (SH bands); 0 else */
    int measure;    /* 0 or LINEAR_MEASURE_SOLID_ANGLE */
} linear_config;

/* The open sky's per-vertex flags (prt_transfer.open_vert) after a member's sets, when tr->open_sky;
 * the reader allocates them and checks each is 0 or 1 (prtfile's validation checks the materials). */
void linear_put_open(prt_writer *w, const prt_transfer *tr);
bool linear_get_open(prt_reader *r, prt_transfer *tr, char *why);

/* The leading fields of cfg. */
linear_config linear_config_of(const transfer_config *cfg);
/* Zeroes cfg and copies the member's private config (size bytes, linear_config first) into it. */
void linear_store(transfer_config *cfg, const void *priv, size_t size);
/* N (default LINEAR_DEFAULT_N, 1..CUBE_TEXELS) and qbits (default 8; 8, 16 or 32) from s into lc
 * (order and measure 0). 0, or -1 with err. */
int linear_configure(const transfer_setup *s, linear_config *lc, prt_error *err);

/* transfer_ops members. */
void linear_write(prt_writer *w, const prt_transfer *tr);
bool linear_read(prt_reader *r, prt_transfer *tr, char *why);
/* Validates tr's sets against d with coefficient indices below max_index. */
bool linear_validate(const struct prt_data *d, const prt_transfer *tr, uint32_t max_index, char *why);
void linear_release(prt_transfer *tr);
size_t linear_bytes(const prt_transfer *tr);

/* transfer_linear members. */
/* transport_init with cfg's N and qbits and no other policy: every vector its N largest (transport.h). */
int linear_init_set(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts,
                    const int *nvec, prt_error *err);
/* transfer_linear.vector_bytes for N coefficients of qbits: three channels of qbits and about 1.5
 * bytes of index and runs per coefficient (teapot-lambert's 547 bytes per vector of 128 at 8 bits,
 * the bench's 570). */
double linear_vector_bytes(const transfer_config *cfg);
double linear_compress(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch);
extern const transfer_glsl linear_glsl;
#endif
