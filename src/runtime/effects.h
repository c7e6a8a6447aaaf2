/* effects.h - the effects a .prt file was made for: what `prt precompute`'s effects plan decided
 * about the local lights' indirect light (one bounce by two VSGLs, indirect highlights), so that
 * every runtime user (render, view, bench) simulates by default what the scene calls for, and
 * only that; their flags force either way.
 *
 * Usage:
 *     prt_effects fx;
 *     prt_file_effects(&data, &fx);                  // after prtfile_read and the lights applied
 *     runtime_desc rd = { .local_bounce = fx.local_bounce, .highlight_samples = fx.highlights ? 32 : 0 };
 *
 * The rule is the plan's (precompute.h, its local-lights lines; planfx.h measures them): there must
 * be local lights; the one bounce where the plan's line says "needed" (it carries at least 2% of
 * the lights' direct light at the planning sample, or it was forced); the highlights where a
 * material has a vMF lobe fit (phong, blinn, ggx, beckmann: lightmat.h) and the plan's highlights
 * line says "needed". Files whose plan has no such lines (lights added at render time) fall back
 * on the hit fraction: the one bounce, and with it the highlights, where surfaces see each other
 * (at least PRT_EFFECTS_HIT_MIN of the planning sample's visibility rays hit geometry). Pure: reads
 * d only. */
#ifndef PRT_EFFECTS_H
#define PRT_EFFECTS_H
#include "prtfile.h"

/* Surfaces see each other at or above this share of hitting visibility rays (precompute's). */
#define PRT_EFFECTS_HIT_MIN 0.005

typedef struct prt_effects {
    bool local_bounce;          /* the local lights' one bounce (two VSGLs per light) */
    bool highlights;            /* their indirect highlights */
    const char *no_bounce;      /* why not (static text), NULL when local_bounce */
    const char *no_highlights;  /* why not, NULL when highlights */
} prt_effects;

/* The effects d was made for, as the header says, into *out. */
void prt_file_effects(const prt_data *d, prt_effects *out);
#endif
