/* lightmat.c - per-material lobes for the local-light modules (lightmat.h).
 *
 * The fits are the same lobefit tables the vMF transfer uses, so the local lights'
 * indirect light and the probe's glossy path agree on what a material reflects. */
#include "lightmat.h"
#include "lobefit.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>

struct lightmat {
    int n;
    brdf_params brdf[PRT_MAX_MATERIALS];
    bool glossy[PRT_MAX_MATERIALS];
    lobefit_table fit[PRT_MAX_MATERIALS];
};

/* Copies the materials and fits the four lobe models once each. */
lightmat *lightmat_create(const prt_scene *s, prt_error *err)
{
    lightmat *lm = prt_calloc(1, sizeof *lm, err);
    if (!lm) return NULL;
    lm->n = s->nmaterials;
    for (int m = 0; m < s->nmaterials; m++) {
        lm->brdf[m] = s->materials[m];
        if (!lobefit_supported(s->materials[m].type)) continue;
        lobefit_desc d = { .views = 16, .res = 128 };
        if (lobefit_fit(&s->materials[m], &d, &lm->fit[m], err)) {
            free(lm);
            return NULL;
        }
        lm->glossy[m] = true;
    }
    return lm;
}

/* Frees the table. */
void lightmat_destroy(lightmat *lm) { free(lm); }

/* Number of materials copied. */
int lightmat_count(const lightmat *lm) { return lm->n; }

/* Material m's BRDF parameters. */
const brdf_params *lightmat_brdf(const lightmat *lm, int m)
{
    PRT_CHECK(m >= 0 && m < lm->n);
    return &lm->brdf[m];
}

/* Whether m has a lobe fit. */
bool lightmat_glossy(const lightmat *lm, int m) { return m >= 0 && m < lm->n && lm->glossy[m]; }

/* The fitted table, or NULL for a diffuse-only material. */
const lobefit_table *lightmat_fit(const lightmat *lm, int m) { return lightmat_glossy(lm, m) ? &lm->fit[m] : NULL; }

/* lobefit_lookup in brdf_frame(n), the lobe axis rotated back to world. */
bool lightmat_lobe(const lightmat *lm, int m, const float n[3], const float wo[3], vmf_lobe *lobe, float alpha[3])
{
    alpha[0] = alpha[1] = alpha[2] = 0;
    if (!lightmat_glossy(lm, m)) return false;
    float s[3], t[3], wl[3];
    brdf_frame(n, s, t);
    brdf_to_local(s, t, n, wo, wl);
    if (wl[2] <= 1e-4f) return false;
    vmf_lobe loc;
    lobefit_lookup(&lm->fit[m], wl, &loc, alpha);
    for (int i = 0; i < 3; i++) lobe->mu[i] = s[i] * loc.mu[0] + t[i] * loc.mu[1] + n[i] * loc.mu[2];
    v3_normalize(lobe->mu);
    lobe->kappa = loc.kappa;
    return true;
}

/* brdf_eval minus the plain kd/pi term (phong, blinn, ggx, beckmann). */
void lightmat_spec_eval(const lightmat *lm, int m, const float n[3], const float wi[3], const float wo[3],
                        float rgb[3])
{
    rgb[0] = rgb[1] = rgb[2] = 0;
    if (!lightmat_glossy(lm, m)) return;
    float s[3], t[3], il[3], ol[3];
    brdf_frame(n, s, t);
    brdf_to_local(s, t, n, wi, il);
    brdf_to_local(s, t, n, wo, ol);
    if (il[2] <= 0 || ol[2] <= 0) return;
    const brdf_params *p = &lm->brdf[m];
    brdf_eval(p, il, ol, rgb);
    for (int k = 0; k < 3; k++) rgb[k] = fmaxf(0.f, rgb[k] - p->kd[k] * (float)M_1_PI);
}

/* Barycentric interpolation of the hit triangle, as the path tracer's surf_from_hit. */
int lightmat_surface(const lightmat *lm, const prt_mesh *m, const vis_hit *h, float pos[3], float nrm[3])
{
    const uint32_t *tri = m->tris + 3 * (size_t)h->tri;
    float b[3] = { 1.f - h->u - h->v, h->u, h->v };
    for (int c = 0; c < 3; c++) {
        pos[c] = nrm[c] = 0;
        for (int k = 0; k < 3; k++) {
            pos[c] += b[k] * m->pos[3 * tri[k] + c];
            nrm[c] += b[k] * m->nrm[3 * tri[k] + c];
        }
    }
    if (v3_normalize(nrm) == 0.f) {
        v3_copy(nrm, h->ng);
        v3_normalize(nrm);
    }
    int mat = m->mat ? m->mat[tri[0]] : 0;
    return mat < lm->n ? mat : 0;
}
