/* indirect.h - local lights' one bounce (two VSGLs per light) and indirect highlights at
 * the vertices: the CPU runtime's per-vertex stage for the local lights' indirect light, beside the
 * direct light of direct.h.
 *
 * Usage:
 *     indirect_ctx *ic = indirect_create(&scene, &(indirect_desc){ 0 }, &err);  // scene SHARED
 *     indirect_set_env(ic, env);                  // the prefiltered probe, or NULL (highlights)
 *     indirect_set_lights(ic, &lights, &err);    // light move: RSM + VSGLs per light
 *     indirect_shade_vertices(ic, eye, rgb);      // view change: ADDS to rgb[3 * nverts]
 *     indirect_destroy(ic);
 *
 * Light move: per light, rsm_render (res desc.rsm_res per face or square) and vsgl_build
 * (vsgl.h), then the view-independent VSGL light at every Lambert vertex (vsgl_shade: its
 * diffuse lobe only). View change at the glossy vertices: with desc.no_highlights,
 * vsgl_shade toward the eye (both lobes); otherwise vsgl_shade_diffuse for the diffuse lobe
 * and hl_shade for the glossy one (highlights.h: desc.hl_samples secondary rays per glossy
 * vertex, seeded by the vertex index so that a still view does not flicker; the indirect
 * highlights from glossy hits and the final gather from diffuse ones, so the glossy lobe's
 * one bounce is counted once) from every light and the probe. Vertices whose normal faces away from the eye get nothing (as
 * direct.h). Both stages run on desc.threads (0: all cores).
 *
 * The VSGLs have no visibility (tokuyoshi's poster has none); the highlights trace theirs.
 * Ownership: the context owns its BVH, maps and buffers; scene and env stay the caller's.
 * Errors: NULL / -1 and one line (no memory, a bad rsm_res, an invalid light). */
#ifndef PRT_INDIRECT_H
#define PRT_INDIRECT_H
#include "vsgl.h"
#include "highlights.h"

typedef struct indirect_desc {
    int rsm_res;          /* RSM texels per side; 0: RSM_DEFAULT_RES (64) */
    int hl_samples;       /* secondary rays per glossy vertex; 0: HL_DEFAULT_SAMPLES (32) */
    int hl_clusters;      /* 0: HL_DEFAULT_CLUSTERS (2) */
    bool no_highlights;   /* skip the indirect highlights */
    bool no_bounce;       /* skip the VSGLs */
    int threads;          /* 0: all cores */
    const vis_scene *vs;  /* the scene's BVH when the caller has one (borrowed: kept alive by the
                           * caller, e.g. direct_vis); NULL: indirect_create builds its own */
} indirect_desc;

typedef struct indirect_stats {
    int lights;
    double light_ms;      /* last indirect_set_lights: RSMs, VSGLs, Lambert vertices */
    double rsm_ms;        /* its RSM part */
    double view_ms;       /* last indirect_shade_vertices (glossy VSGL light and highlights) */
    int glossy_vertices;  /* shaded at each view change */
    long hl_rays;         /* secondary and shadow rays of the last view change */
} indirect_stats;

typedef struct indirect_ctx indirect_ctx;

/* Builds the BVH and the material lobes over scene (kept, not copied). NULL with err. */
indirect_ctx *indirect_create(const prt_scene *scene, const indirect_desc *desc, prt_error *err);
/* Frees it (NULL is fine). */
void indirect_destroy(indirect_ctx *ic);
/* The prefiltered probe the highlights read (NULL: local lights only). */
void indirect_set_env(indirect_ctx *ic, const prefilter_env *env);
/* Light move: validates and copies ls, renders an RSM and two VSGLs per light. -1 with err. */
int indirect_set_lights(indirect_ctx *ic, const prt_lights *ls, prt_error *err);
/* View change: adds the one bounce and the highlights toward eye to rgb[3 * nverts]. */
void indirect_shade_vertices(indirect_ctx *ic, const float eye[3], float *rgb);
/* The VSGLs of light l (after indirect_set_lights), for a GPU runtime's uniforms. */
const vsgl_pair *indirect_vsgls(const indirect_ctx *ic, int l);
/* The last calls' figures. */
void indirect_get_stats(const indirect_ctx *ic, indirect_stats *st);
#endif
