/* brdf.h - analytic BRDF models, evaluated and sampled in a local frame.
 *
 * Usage:
 *     brdf_params p; prt_error err;
 *     if (brdf_parse("phong:kd=0.6,0.05,0.05;ks=0.4;n=50", &p, &err)) puts(err.msg);
 *     float rgb[3]; brdf_eval(&p, wi, wo, rgb);      // f_r, no cosine
 *
 * Local frame: z is the normal, x the tangent s, y the binormal t (brdf_frame
 * gives Eq. 10's stereographic frame for a normal). Directions point away from
 * the surface. brdf_eval returns 0 when either direction is below the horizon.
 * Every model is reciprocal: f(wi,wo) = f(wo,wi) (tested).
 *
 * Spec strings, "model:key=value;key=value" (a value is 1 number, or 3 for RGB):
 *   lambert:kd=R,G,B
 *   phong:kd=..;ks=..;n=EXP                 modified Phong, kd/pi + ks (n+2)/(2pi) cos^n(alpha)
 *   blinn:kd=..;ks=..;n=EXP                 kd/pi + ks (n+8)/(8pi) (n.h)^n
 *   as:kd=..;ks=..;nu=..;nv=..              Ashikhmin-Shirley 2000 anisotropic (nu along s, nv along t)
 *   lafortune:kd=..;lobe=Cx,Cy,Cz,n[;lobe=...]   up to 4 lobes: kd/pi + sum [Cx wx vx + Cy wy vy + Cz wz vz]^n
 *   ggx:kd=..;ks=F0;alpha=A                 Cook-Torrance, GGX D, height-correlated Smith G, Schlick F
 *   beckmann:kd=..;ks=F0;alpha=A            the same with the Beckmann distribution
 * Named presets: "paper-phong" (red diffuse, exponent 50), "paper-as" (kd 0.5, ks 0.75, nu 10, nv 100).
 * Missing keys take defaults (kd 0.5, ks 0.5, n 50, nu=nv 100, alpha 0.2; Lafortune without a
 * lobe gets -1.0288,-1.0288,1.0288,50, the Phong lobe of ks 0.5, n 50 at its peak).
 * Ranges: kd, ks >= 0 (ks <= 1 where it is a Fresnel F0: as, ggx, beckmann), exponents in
 * [0, 1e6], alpha in [0.001, 2]. AS uses its own coupled diffuse term (AS 2000 Eq. 5,
 * kd = Rd, ks = Rs); the microfacet models add a plain kd/pi, so with kd > 0 their
 * albedo can exceed 1 at grazing angles. Blinn's (n+8)/(8pi) overshoots the exact
 * normalization by up to 4%. Nothing stops a spec from reflecting more than it receives
 * (phong:kd=2;ks=3 reflects 5 times the light at normal incidence): such a BRDF is accepted,
 * and precompute's effects plan warns of it (albedo.h: the directional albedo by quadrature
 * above 1.05 at 0-60 degrees), since a glowing surface may be meant; its interreflections gain
 * energy.
 *
 * Sampling: a one-sample mixture of cosine-weighted diffuse and the model's lobe (Phong:
 * cos^n around the mirror direction; Blinn, AS (AS 2000 Eq. 9), GGX, Beckmann: half
 * vectors; Lafortune: cos^n around each lobe's peak C*wo, or diffuse when the peak is
 * below the horizon), weighted by the luminance of kd and ks (Lafortune: each lobe's
 * approximate albedo). brdf_pdf is exactly that mixture's density.
 *
 * Errors: brdf_parse fails with one line naming the spec and the problem
 * (unknown model, unknown key, bad number, value out of range). */
#ifndef PRT_BRDF_H
#define PRT_BRDF_H
#include "common.h"

typedef enum brdf_type {
    BRDF_LAMBERT = 0, BRDF_PHONG, BRDF_BLINN, BRDF_AS, BRDF_LAFORTUNE, BRDF_GGX, BRDF_BECKMANN
} brdf_type;

#define BRDF_MAX_LOBES 4

typedef struct brdf_params {
    brdf_type type;
    float kd[3];          /* diffuse albedo (Lambert term kd/pi) */
    float ks[3];          /* specular scale; F0 for the microfacet models */
    float n;              /* Phong / Blinn exponent */
    float nu, nv;         /* Ashikhmin-Shirley exponents */
    float alpha;          /* microfacet roughness (GGX/Beckmann alpha) */
    int nlobes;           /* Lafortune */
    float lobe[BRDF_MAX_LOBES][4]; /* Cx, Cy, Cz, n */
} brdf_params;

/* Parses a spec string (see header). Returns 0, or -1 with err set. */
int brdf_parse(const char *spec, brdf_params *out, prt_error *err);
/* Writes the canonical spec of p into buf: every number in its shortest decimal that parses back
 * to the same float, so brdf_parse(brdf_format(p)) gives p bit for bit (-0 is parsed as 0). */
void brdf_format(const brdf_params *p, char *buf, size_t cap);
/* Short model name ("phong"). */
const char *brdf_type_name(brdf_type t);

/* f_r(wi, wo) per channel, no cosine factor. Local frame. */
void brdf_eval(const brdf_params *p, const float wi[3], const float wo[3], float rgb[3]);

/* Importance sampling for the path tracer: picks wi given wo from u1,u2 in [0,1),
 * writes the pdf (solid angle) of the returned direction. Returns false when no
 * direction could be made (wo below the horizon, or a sample under the surface). */
bool brdf_sample(const brdf_params *p, const float wo[3], float u1, float u2, float wi[3], float *pdf);
/* pdf (solid angle) with which brdf_sample picks wi given wo. */
float brdf_pdf(const brdf_params *p, const float wo[3], const float wi[3]);

/* Eq. 10's tangent frame from a unit normal: s = normalize[(ny+1)^2 + nz^2 - nx^2, -2(ny+1)nx, -2 nx nz],
 * t = n x s. Its one discontinuity is at n = (0,-1,0); within 1e-6 of it a fixed frame is used. */
void brdf_frame(const float n[3], float s[3], float t[3]);
/* World direction w to local (w.s, w.t, w.n). */
static inline void brdf_to_local(const float s[3], const float t[3], const float n[3], const float w[3], float out[3]) {
    out[0] = s[0] * w[0] + s[1] * w[1] + s[2] * w[2];
    out[1] = t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
    out[2] = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
}
#endif
