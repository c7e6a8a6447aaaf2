/* prt.h - prt as a library: make, load and relight all-frequency precomputed radiance transfer.
 *
 * prt implements Wang, Tran & Luebke 2006, "All-frequency relighting of glossy objects": the
 * light transport toward every vertex of a scene (visibility, interreflections, each material's
 * BRDF factored into a few terms) is precomputed once against a 6x64x64 cube of light directions,
 * compressed with wavelets and stored in a .prt file; afterwards the scene is relit under any
 * environment light (a light probe, turned at will) from any viewpoint at interactive rates, on
 * the CPU or in GLSL. This header includes the whole public API; each header it names is the
 * manual of its part, and docs/api.md is the map:
 *
 *     error.h       prt_error: how every call reports bad input
 *     common.h      version, threads, progress callbacks, atomic file output
 *     image.h       float images: image_read, image_write (EXR linear; PNG 8-bit sRGB)
 *     probe.h       light probes: probe_load, rotations, the procedural sky
 *     camera.h      the pinhole camera every image is made through
 *     prtfile.h     prt_data, the .prt file: prtfile_read, prtfile_write, prt_data_free
 *     runtime.h     relighting a prt_data: runtime_create on a backend ("cpu", "gl"), light and view changes
 *     lights.h      local point and spot lights (runtime_set_local_lights)
 *     scene.h       scenes to precompute: an OBJ model or a JSON scene
 *     precompute.h  precompute_run: a scene into a prt_data, what `prt precompute` does (a zeroed desc,
 *                   the scene's own keys applied by precompute_desc_apply_scene)
 *
 * Usage: relight a .prt file under a probe turned 30 degrees about +y and write a PNG
 * (examples/relight.c is this program with its arguments and every error said):
 *
 *     #include "prt.h"
 *     prt_error err = { { 0 } };
 *     prt_data d = { 0 };  prt_probe probe = { 0 };  prt_image img = { 0 };  prt_runtime *rt = NULL;
 *     float R[9], b0[3], b1[3];
 *     int rc = 1;
 *     probe_rotation(30, 0, R);                                  // a light at d moves to R d
 *     render_desc rd = { .width = 800, .height = 600, .background = &probe, .background_rotation = R };
 *     if (prtfile_read("bunny.prt", &d, &err) || probe_load("city.exr", PROBE_AUTO, &probe, &err)) goto done;
 *     scene_focus_bounds(&d.scene, b0, b1);
 *     camera_default(b0, b1, 800.0f / 600, &rd.camera);          // framed as `prt render` frames it
 *     if (!(rt = runtime_create(&d, &(runtime_desc){ .backend = "cpu" }, &err)) ||
 *         runtime_set_light(rt, &probe, R, &err) ||              // light change: T x L
 *         runtime_render(rt, &rd, &img, &err) ||                 // view change and raster, read back
 *         image_write("out.png", &img, &(image_desc){ 0 }, &err)) goto done;
 *     rc = 0;
 *     done: if (rc) fprintf(stderr, "%s\n", err.msg);
 *     runtime_destroy(rt); image_free(&img); probe_free(&probe); prt_data_free(&d);
 *
 * Errors: a call that can fail on its input returns 0, or -1 (a constructor: NULL) after writing
 * one line that names the file and the problem into the caller's prt_error; the library prints
 * no error and sets nothing global (precompute_run prints its plan unless desc.quiet). A broken invariant inside the library is a bug, never a way of
 * rejecting input: PRT_CHECK (check.h) prints it and aborts.
 *
 * Ownership: what a call fills (prt_data, prt_probe, prt_image, prt_scene) is the caller's, freed
 * by its module's free (prt_data_free, probe_free, image_free, scene_free), which accepts a zeroed
 * struct, so one cleanup path serves every failure; runtime_destroy accepts NULL. A runtime
 * borrows its prt_data (keep it until runtime_destroy); precompute_run takes its scene over.
 *
 * Threads: the library keeps no mutable globals: all state is in structs the caller owns, and
 * calls on separate objects do not share any. One object is used from one thread at a time
 * (runtime.h: how a GL runtime makes its context current). The library's own loops run on every
 * core; runtime_desc.threads, precompute_desc.nthreads or $PRT_THREADS say how many.
 *
 * Link (docs/api.md):
 *     cc app.c $(pkg-config --cflags --libs prt)                     shared: libprt.so.1
 *     cc app.c $(pkg-config --cflags prt) $(pkg-config --static --libs prt | sed 's/-lprt\b/-l:libprt.a/')
 * The headers are C11 (-std=c11 or later; gcc or clang) and compile as C++ too. */
#ifndef PRT_H
#define PRT_H
#ifdef __cplusplus
extern "C" {
#endif
#include "error.h"
#include "common.h"
#include "image.h"
#include "probe.h"
#include "camera.h"
#include "prtfile.h"
#include "runtime.h"
#include "lights.h"
#include "scene.h"
#include "precompute.h"
#include "driver.h"
#ifdef __cplusplus
}
#endif
#endif
