/* absent.c - the functions a fuzz harness links but never calls, standing in for the libraries
 * behind them, so that a harness needs no shared library beyond libc, libstdc++, zlib and cJSON (and
 * assimp for the asset harnesses, whose readers they fuzz)
 * (tools/fuzz_pack.sh copies the binaries to machines without this one's packages; OpenImageIO,
 * OSMesa, Embree, OpenBLAS and OpenMPI would bring some 280 shared libraries, 590 MB, along).
 *
 * Linked before libprt.a (Makefile, fuzz rules), these definitions keep the archive members
 * that wrap the libraries out of the link: image_oiio.o (OpenImageIO: image files), glctx.o
 * (OSMesa, EGL, GLFW: the gl backend's contexts), visibility.o (Embree: local lights' shadow
 * rays) and shard.o (OpenMPI); LAPACKE and OpenBLAS, which factor.c, refit.c and cpca_build.c
 * call only while precomputing, are stood in for one by one. The harnesses read bytes from memory and
 * relight on the CPU backend without local lights, so none of these runs; one that did would
 * abort with its name, a finding that says to link the library again. A new call into one of
 * these members shows at link time: the member comes in and its definitions clash with these. */
#include <stdio.h>
#include <stdlib.h>

static void absent(const char *name) {
    fprintf(stderr, "fuzz build: %s called, but the harnesses link without its library (tests/fuzz/absent.c)\n", name);
    abort();
}

/* Any signature: the stand-in never returns, and no header declares it in this file. */
#define ABSENT(name) \
    void name(void); \
    void name(void) { absent(#name); }

/* image_oiio.o (OpenImageIO) */
ABSENT(image_read)
ABSENT(image_read_memory)
ABSENT(image_tonemapped)
ABSENT(image_write)
/* glctx.o (OSMesa, EGL, GLFW) */
ABSENT(glctx_check)
ABSENT(glctx_compute_program)
ABSENT(glctx_create)
ABSENT(glctx_destroy)
ABSENT(glctx_kind_from_env)
ABSENT(glctx_kind_name)
ABSENT(glctx_make_current)
ABSENT(glctx_program)
/* visibility.o (Embree) */
ABSENT(vis_closest)
ABSENT(vis_closest_many)
ABSENT(vis_create)
ABSENT(vis_destroy)
ABSENT(vis_eps)
ABSENT(vis_occluded)
/* shard.o (OpenMPI) */
ABSENT(shard_pass_begin)
ABSENT(shard_pass_end)
ABSENT(shard_pass_poll)
ABSENT(shard_rank)
ABSENT(shard_share_list)
ABSENT(shard_share_rows)
ABSENT(shard_size)
ABSENT(shard_split)
ABSENT(shard_status)
/* LAPACKE and OpenBLAS (factor.c's SVD and eigen solvers, refit.c's Cholesky, cpca_build.c's
 * eigen solver and least squares) */
ABSENT(LAPACKE_dgesdd)
ABSENT(LAPACKE_dormtr)
ABSENT(LAPACKE_dpotrf)
ABSENT(LAPACKE_dposv)
ABSENT(LAPACKE_dpotrs)
ABSENT(LAPACKE_dstemr)
ABSENT(LAPACKE_dsyev)
ABSENT(LAPACKE_dsterf)
ABSENT(LAPACKE_dsytrd)
ABSENT(LAPACKE_sgesdd)
ABSENT(LAPACKE_sormtr)
ABSENT(LAPACKE_sstemr)
ABSENT(LAPACKE_ssterf)
ABSENT(LAPACKE_ssytrd)
ABSENT(openblas_set_num_threads)
