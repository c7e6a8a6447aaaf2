/* effects.c - the effects a .prt file was made for (effects.h): the effects plan's local-light
 * lines, or its rule over the file's figures. */
#include "effects.h"
#include <string.h>

/* Whether material type t has a vMF lobe fit (lightmat.h): the highlights need one. */
static bool has_lobe(brdf_type t) { return t == BRDF_PHONG || t == BRDF_BLINN || t == BRDF_GGX || t == BRDF_BECKMANN; }

void prt_file_effects(const prt_data *d, prt_effects *out) {
    const char *plan = d->plan;
    bool see = d->stats.hit_fraction >= PRT_EFFECTS_HIT_MIN, lobe = false, hl = true;
    for (int m = 0; m < d->scene.nmaterials; m++) lobe |= has_lobe(d->scene.materials[m].type);
    if (strstr(plan, "one bounce (two VSGLs): none")) see = false;
    else if (strstr(plan, "one bounce (two VSGLs): needed")) see = true;
    if (strstr(plan, "indirect highlights: none")) hl = false;
    else if (!strstr(plan, "indirect highlights: needed")) hl = see;   /* no line: the hit-fraction rule */
    memset(out, 0, sizeof *out);
    if (d->scene.lights.count == 0) {
        out->no_bounce = out->no_highlights = "no local lights";
        return;
    }
    out->no_bounce = see ? NULL : "the plan found too little of the lights' light in one bounce";
    out->no_highlights = !lobe ? "no glossy material" : !hl ? "the plan found too little one-bounce light on glossy surfaces" : NULL;
    out->local_bounce = !out->no_bounce;
    out->highlights = !out->no_highlights;
}
