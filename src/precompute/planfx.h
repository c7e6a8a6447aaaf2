/* planfx.h - the effects plan's measurements: how much light the local lights' one bounce
 * carries, how much of it reaches glossy surfaces, and whether the receivers' vertex spacing can
 * hold the shadow of the sharpest light a file may be lit by. precompute.c's plan decides the
 * local bounce, the indirect highlights and refinement from these figures and prints them.
 *
 * Usage:
 *     planfx_bounce b;
 *     planfx_measure_bounce(&scene, vs, sample, nsample, PLANFX_RAYS, &b);
 *     bool bounce = b.direct > 0 && b.bounce >= PLANFX_BOUNCE_MIN * b.direct;
 *     planfx_receivers rc; planfx_measure_receivers(&scene, &rc);   // rc.refine: the plan's call
 *
 * One bounce (planfx_measure_bounce). At each sampled vertex p (normal n) the direct irradiance
 * from every local light, E_d = sum_l I_l(-w) max(n.w, 0) / d^2 V (lights.h, one shadow ray), and
 * the one-bounce irradiance E_1 = integral of L(w) max(n.w, 0) dw, estimated as pi times the mean
 * radiance along `rays` cosine-distributed directions (pdf cos / pi, so E_1 = (pi / R) sum L): L is
 * the radiance the first hit q reflects toward p from every light (light_shade: q's analytic BRDF,
 * its glossy lobe included, one shadow ray per light), 0 for a miss or a hit on a surface's back.
 * The directions are a rank-1 lattice (i + a) / R, frac(i / phi + b), shifted by (a, b) hashed from
 * the vertex index, so the figure is deterministic and unbiased. Shares are luminance sums over the
 * sample: bounce / direct is the light the one bounce adds against the direct light; glossy /
 * direct the part of it that falls on glossy receivers (not Lambert), whose lobes the indirect
 * highlights reflect. Exact cases the tests use: a point light over a lone plane, 0 (no ray from
 * the plane hits anything); a point light at the centre of a closed Lambert sphere of albedo kd,
 * kd (every point of a sphere sees every other with the form factor dA / (4 pi R^2), so the
 * radiosity kd E_d / pi fills the hemisphere and E_1 = kd E_d); in modified Phong kd + ks, all of it
 * at glossy receivers (each hit's mirror direction is its normal, and the chord makes the same angle
 * at both ends, so E_1 / E_d is the lobe's cosine-weighted integral).
 * Cost: rays x (1 + lights) rays per vertex; 200 vertices x 64 rays take a few milliseconds.
 *
 * Receivers (planfx_measure_receivers). With a floor under models, the floor's vertex spacing (the
 * mean of each floor triangle's shortest edge: a grid's step) against the penumbra a sun casts
 * from the models' top over the floor: a light of angular diameter a behind an edge at height h
 * blurs the shadow over h tan(a) on a receiver facing it (wider at grazing light: this is the
 * sharpest case). Per-vertex transport holds a shadow edge only to the vertex spacing, so where the
 * spacing is wider than that penumbra the edge is smeared over a step and the floor must be
 * refined (refine.h) for the shadow to be held; a local light in the scene (a point: no penumbra)
 * asks for it too. Without a floor or without models nothing is decided here (refine: false).
 *
 * Pure functions of their arguments (the scene and its BVH are only read); thread-safe. */
#ifndef PRT_PLANFX_H
#define PRT_PLANFX_H
#include "scene.h"
#include "visibility.h"

/* The one bounce is simulated when it adds at least this share of the direct light at the sampled
 * vertices: below 2% the image changes by less than the accuracy target's 2 points of reference
 * noise (a bounce adds light, so its share bounds its image error), while it costs two VSGLs per
 * light at every light move. The indirect highlights use the same share of the glossy receivers'
 * one-bounce light (their lobes reflect part of it: the share bounds what they can add). */
#define PLANFX_BOUNCE_MIN 0.02
#define PLANFX_HIGHLIGHT_MIN 0.02
/* Directions per sampled vertex: at 200 vertices, 12,800 rays give the share to about 1% of
 * itself (independent rays: 1 / sqrt(12,800)), far finer than the 2% threshold needs. */
#define PLANFX_RAYS 64
/* Why the plan reports the receivers' need without refining the floor where its shadows keep the cosine
 * (force_refine 1 refines): on the teapot over its 2,500-vertex floor, direct light, sunrise and studio
 * at two yaws, the floor's shadow region was no closer to the path tracer after refinement within 1.5x
 * or 3x the vertices (docs/design/plan.md), while the passes and the file grow with the vertices. Where
 * they are folded (opensky.h "The floor's fold") a low sun's silhouette survives truncation, the floor's
 * vertex spacing is then what blurs it, and refining it up to PLANFX_FLOOR_GROWTH times its vertices
 * measured closer in every cell of the Lambertian teapot's matrix (docs/design/shadows.md). */
#define PLANFX_REFINE_MEASURED "refining 1.5x or 3x measured no closer to the path tracer on such a floor"
#define PLANFX_FLOOR_GROWTH 2.5
/* The models are refined by default where visibility changes across their edges, up to this many
 * times their vertices: a self-shadow edge (the spout's on the body, the lid's rim) and a glossy lobe
 * cut by an occluder change within a vertex, and the vertices interpolate them. Against the path
 * tracer the gain flattens past about 2.5x while the passes' time and the file grow with the vertices
 * (docs/design/plan.md, "Refinement of the models", has the measurements). */
#define PLANFX_MODEL_GROWTH 2.5
/* The file's byte budget refinement keeps within: the bench file's size, as the view grid's
 * VMFT_PLAN_BYTES (transfer_linear.vector_bytes models the linear transfer's part). */
#define PLANFX_FILE_BYTES 96e6
/* The sun's angular diameter (0.53 degrees, in radians): the sharpest light a probe holds. */
#define PLANFX_SUN_RAD 0.00925

typedef struct planfx_bounce {
    double direct;      /* sum over the sample of the direct irradiance's luminance */
    double bounce;      /* of the one-bounce irradiance's, every receiver */
    double glossy;      /* of the one-bounce irradiance's at the glossy receivers */
    int vertices;       /* sampled vertices */
    int glossy_vertices;
    long rays;          /* rays traced (directions and shadow rays) */
} planfx_bounce;

typedef struct planfx_receivers {
    bool floor, models; /* the scene has a floor, and models above it */
    double spacing;     /* the floor's vertex spacing (scene units) */
    double height;      /* the models' highest point over the floor's plane */
    double penumbra;    /* the sun's penumbra from that height: height * tan(PLANFX_SUN_RAD) */
    bool point_light;   /* a local light (a hard shadow edge) */
    bool refine;        /* the floor should be refined: spacing > penumbra, or a local light */
} planfx_receivers;

/* Measures the local lights' one bounce at s->mesh's vertices verts[0..n) with `rays` directions
 * each (header), vs built on s->mesh. out is zero when the scene has no lights. */
void planfx_measure_bounce(const prt_scene *s, const vis_scene *vs, const int *verts, int n, int rays, planfx_bounce *out);

/* The floor's spacing against the sun's penumbra from the models' height (header). */
void planfx_measure_receivers(const prt_scene *s, planfx_receivers *out);
#endif
