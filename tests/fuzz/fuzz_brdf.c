/* fuzz_brdf.c - BRDF specs (brdf_parse) on arbitrary text. An accepted spec: its canonical
 * form (brdf_format) parses again to the same parameters and formats to the same string (the
 * round trip brdf.h promises), and the BRDF is finite and non-negative in a few directions; a
 * refused one: one line. (A spec has no file, so the error names none.) */
#include "fuzz.h"
#include "brdf.h"

/* Parameters equal as numbers (so 0 and -0 agree: the canonical spec parses -0 as 0). */
static bool same_params(const brdf_params *a, const brdf_params *b) {
    if (a->type != b->type || a->nlobes != b->nlobes) return false;
    for (int k = 0; k < 3; k++) if (a->kd[k] != b->kd[k] || a->ks[k] != b->ks[k]) return false;
    if (a->n != b->n || a->nu != b->nu || a->nv != b->nv || a->alpha != b->alpha) return false;
    for (int l = 0; l < a->nlobes && l < BRDF_MAX_LOBES; l++)
        for (int k = 0; k < 4; k++) if (a->lobe[l][k] != b->lobe[l][k]) return false;
    return true;
}

/* f_r in a few fixed directions of the local frame (z up): finite and >= 0. */
static void check_eval(const brdf_params *p) {
    static const float dirs[4][3] = { { 0, 0, 1 }, { 0.6f, 0, 0.8f }, { -0.48f, 0.6f, 0.64f }, { 0.99f, 0, 0.141067f } };
    for (int i = 0; i < 4; i++)
        for (int o = 0; o < 4; o++) {
            float f[3];
            brdf_eval(p, dirs[i], dirs[o], f);
            for (int k = 0; k < 3; k++) FUZZ_REQUIRE(isfinite(f[k]) && f[k] >= 0, "f_r = %g", (double)f[k]);
        }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char *spec = fuzz_cstr(data, size);
    brdf_params p, q;
    prt_error err = { { 0 } };
    if (brdf_parse(spec, &p, &err) == 0) {
        char a[512], b[512];
        brdf_format(&p, a, sizeof a);
        prt_error e2 = { { 0 } };
        FUZZ_REQUIRE(brdf_parse(a, &q, &e2) == 0, "canonical spec '%s' of '%s' refused: %s", a, spec, e2.msg);
        FUZZ_REQUIRE(same_params(&p, &q), "canonical spec '%s' of '%s' parses to other values", a, spec);
        brdf_format(&q, b, sizeof b);
        FUZZ_REQUIRE(!strcmp(a, b), "canonical spec not stable: '%s' then '%s'", a, b);
        check_eval(&p);
    } else {
        fuzz_check_error(&err, NULL);
    }
    free(spec);
    return 0;
}
